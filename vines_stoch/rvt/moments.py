"""Means and covariances of a linear(ised) model (MODEL.md section 6): the stationary covariance
(Lyapunov equation), the time-varying one from the scene's start on a time grid (the exact
transition of each step, ``P <- Phi P Phi^T + sum_j e_j^2 Q_j``: exact at the grid's times for
envelopes constant over a step, as the engine's filter step takes them), the harmonic mean
response, and the response spectrum ``|H|^2 S0``."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.linalg import expm, solve_continuous_lyapunov

from ..physics.filters import step_covariance
from ..physics.loads import STATIONARY, envelope
from .system import Model, NotApplicable


def stable(a: np.ndarray) -> bool:
    """True when every eigenvalue of ``a`` has a negative real part (a stationary law exists)."""
    return bool(np.linalg.eigvals(a).real.max() < 0.0) if a.size else True


def stationary_covariance(model: Model) -> np.ndarray:
    """``P`` with ``A P + P A^T + B B^T = 0`` (envelopes at 1); NotApplicable where ``A`` is not
    stable (no stationary law: an undamped mode, an unstable equilibrium)."""
    if not stable(model.a):
        raise NotApplicable("no stationary law: the (linearised) system has an undamped or unstable mode")
    p = solve_continuous_lyapunov(model.a, -model.noise @ model.noise.T)
    return 0.5 * (p + p.T)


def harmonic_amplitudes(model: Model) -> list[tuple[float, np.ndarray]]:
    """``(omega, X)``: the steady response ``Re(X e^{i omega t})`` to each harmonic force,
    ``X = (i omega I - A)^{-1} g``."""
    eye = np.eye(model.size)
    return [(w, np.linalg.solve(1j * w * eye - model.a, g)) for w, g, _ in model.harmonics]


def constant_response(model: Model) -> np.ndarray:
    """The equilibrium ``-A^{-1} b`` of the constant forcing (zero where there is none)."""
    if not model.constant.any():
        return np.zeros(model.size)
    try:
        return -np.linalg.solve(model.a, model.constant)
    except np.linalg.LinAlgError:
        raise NotApplicable("a constant force on a body without a spring: no equilibrium") from None


def psd(model: Model, row: np.ndarray, omega: np.ndarray) -> np.ndarray:
    """Two-sided spectrum ``S_y(omega) = |H(omega)|^2 / (2 pi)`` per unit ``dW`` intensity of the
    stationary output ``y = row . z``: ``sum_j |row (i omega - A)^{-1} B_j|^2 / (2 pi)`` (a white
    noise of intensity ``sigma`` has the two-sided PSD ``sigma^2 / (2 pi)``, MODEL.md section 3)."""
    eye = np.eye(model.size)
    out = np.empty(len(omega))
    for i, w in enumerate(omega):
        h = row @ np.linalg.solve(1j * w * eye - model.a, model.noise.astype(complex))
        out[i] = float(np.sum(np.abs(h) ** 2)) / (2.0 * np.pi)
    return out


@dataclass
class Trajectory:
    """Moments on a time grid: ``t`` (N + 1,), means ``m`` (N + 1, n), covariances ``p``
    (N + 1, n, n), and the models they were propagated with (one, or one a step: ``models``)."""

    t: np.ndarray
    m: np.ndarray
    p: np.ndarray
    models: list

    def model_at(self, i: int) -> Model:
        return self.models[min(i, len(self.models) - 1)]


def _step_matrices(model: Model, h: float) -> tuple[np.ndarray, np.ndarray, list[tuple]]:
    """``(Phi, Gamma b, [(envelope, Q)])`` of one step ``h``: the transition, the step's response
    to the constant forcing and the covariance of the noise columns of each envelope, from the
    eigen-decomposition ``A = V L V^-1`` (``_modal_step``) where ``V`` is well conditioned, else
    from ``expm`` of the augmented drift and ``physics.filters.step_covariance`` (Van Loan's
    exponential by scaling and squaring)."""
    groups: dict = {}
    for j, row in enumerate(model.envelopes):
        key = None if row is None or row[0] == STATIONARY else tuple(row)
        groups.setdefault(key, []).append(j)
    covariances = {key: model.noise[:, cols] @ model.noise[:, cols].T for key, cols in groups.items()}
    modal = _modal_step(model, h, covariances)
    if modal is not None:
        return modal
    n = model.size
    block = np.zeros((n + 1, n + 1))
    block[:n, :n] = model.a
    block[:n, n] = model.constant
    e = expm(block * h)
    qs = [(key, step_covariance(model.a, bb, h)) for key, bb in covariances.items()]
    return e[:n, :n], e[:n, n], qs


#: Largest condition number of the eigenvectors for which ``_modal_step`` is used.
CONDITION = 1e6


def _modal_step(model: Model, h: float, covariances: dict) -> tuple | None:
    """The step's matrices (``_step_matrices``) in the eigenvectors of ``A``: ``Phi = V e^{L h} V^-1``,
    ``Gamma b = V ((e^{l h} - 1) / l) V^-1 b``, ``Q = V [C_ij (e^{(l_i + conj l_j) h} - 1) / (l_i + conj
    l_j)] V^H`` with ``C = V^-1 B B^T V^-H`` (the integrals of ``int_0^h e^{A s} B B^T e^{A^T s} ds`` mode
    by mode); None where ``V`` is ill-conditioned (repeated eigenvalues, a defective drift)."""
    lam, v = np.linalg.eig(model.a)
    if not np.all(np.isfinite(lam)) or np.linalg.cond(v) > CONDITION:
        return None
    w = np.linalg.inv(v)
    growth = np.exp(lam * h)

    def integral(rate: np.ndarray) -> np.ndarray:  # int_0^h e^{rate s} ds, (e^{rate h} - 1) / rate
        small = np.abs(rate * h) < 1e-8
        safe = np.where(small, 1.0, rate)
        return np.where(small, h * (1.0 + 0.5 * rate * h), np.expm1(rate * h) / safe)

    phi = np.real((v * growth) @ w)
    forced = np.real(v @ (integral(lam) * (w @ model.constant)))
    pair = integral(lam[:, None] + lam.conj()[None, :])
    qs = []
    for key, bb in covariances.items():
        c = w @ bb @ w.conj().T
        q = np.real(v @ (c * pair) @ v.conj().T)
        qs.append((key, 0.5 * (q + q.T)))
    return phi, forced, qs


def propagate(model: Model, t_end: float, steps: int) -> Trajectory:
    """Means and covariances of a linear model from the scene's start (``model.m0``, ``model.p0``)
    at ``steps + 1`` times over ``[0, t_end]``, exact at the grid's times (harmonic forces by their
    steady response plus the free decay of the difference)."""
    h = t_end / steps
    t = np.linspace(0.0, t_end, steps + 1)
    amplitudes = harmonic_amplitudes(model) if model.harmonics else []
    steady0 = sum((x.real for _, x in amplitudes), np.zeros(model.size))
    m = np.empty((steps + 1, model.size))
    p = np.empty((steps + 1, model.size, model.size))
    m[0], p[0] = model.m0 - steady0, model.p0
    phi, forced, qs = _step_matrices(model, h)  # (one model, one step: once)
    for i in range(steps):
        m[i + 1] = phi @ m[i] + forced
    fixed = _noise(qs, 0.0, phi) if all(key is None for key, _ in qs) else None
    if fixed is not None and not fixed.any() and not p[0].any():
        p[1:] = 0.0  # (no noise from a known start: the covariance stays zero)
    else:
        for i in range(steps):
            q = fixed if fixed is not None else _noise(qs, t[i] + 0.5 * h, phi)
            p[i + 1] = _covariance_step(phi, p[i], q)
    for w, x in amplitudes:
        m += np.real(np.exp(1j * w * t)[:, None] * x[None, :])
    return Trajectory(t, m, p, [model])


#: Largest relative change of the drift between a step's start and its midpoint before the step
#: is split (``propagate_linearized``), and the deepest splitting (a step in 4^depth).
SPLIT, DEPTH = 0.05, 4


def propagate_linearized(model: Model, t_end: float, steps: int,
                         relinearize: Callable[[np.ndarray, np.ndarray], Model]) -> Trajectory:
    """Means and covariances of statistical linearisation from the scene's start on the grid of
    ``steps`` over ``[0, t_end]``: each step is the exact step of the model linearised at the
    step's midpoint moments (predicted by the exact step of the model at its start: a second-order
    exponential integrator of the moment equations), split in four where the two models' drifts
    differ by more than ``SPLIT`` (down to ``DEPTH`` levels; NotApplicable past them).  A model
    frozen over a whole coarse step instead pumps energy into a stiffening law, as a spring whose
    stiffness steps up at its largest stretch."""
    if model.harmonics:
        raise NotApplicable("harmonic forces on a nonlinear absorber: no combined linearisation here")
    t = np.linspace(0.0, t_end, steps + 1)
    m = np.empty((steps + 1, model.size))
    p = np.empty((steps + 1, model.size, model.size))
    m[0], p[0] = model.m0, model.p0
    models = [model]
    cache: dict = {}
    for i in range(steps):
        m[i + 1], p[i + 1], last = _split_step(relinearize, m[i], p[i], t[i], t[i + 1] - t[i], 0, cache)
        models.append(last)
    return Trajectory(t, m, p, models)


#: Largest change of a drift, relative to its largest entry, within which a step reuses the
#: transition computed for an earlier model (``_exact_step``; a linearised law that has settled).
MOVED = 1e-3


def _exact_step(model: Model, m: np.ndarray, p: np.ndarray, t0: float, h: float,
                cache: dict) -> tuple[np.ndarray, np.ndarray]:
    """One exact step ``h`` of ``model`` from ``(m, p)`` at ``t0``; the matrices of the last two
    models seen are kept in ``cache`` and reused for a model whose drift and forcing lie within
    ``MOVED`` of theirs."""
    scale = max(np.abs(model.a).max(), 1e-300)
    matrices = None
    for a, constant, step, found in cache.get("kept", []):
        if (step == h and np.abs(a - model.a).max() <= MOVED * scale
                and np.abs(constant - model.constant).max() <= MOVED * max(np.abs(constant).max(), 1e-300)):
            matrices = found
            break
    if matrices is None:
        matrices = _step_matrices(model, h)
        cache["kept"] = [(model.a, model.constant, h, matrices)] + cache.get("kept", [])[:1]
    phi, forced, qs = matrices
    return phi @ m + forced, _covariance_step(phi, p, _noise(qs, t0 + 0.5 * h, phi))


def _noise(qs: list[tuple], t: float, phi: np.ndarray) -> np.ndarray:
    """The covariance a step adds, ``sum_j e_j(t)^2 Q_j``, its envelopes at ``t``."""
    return sum((_scale(k, t) ** 2 * cov for k, cov in qs), np.zeros_like(phi))


def _covariance_step(phi: np.ndarray, p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """``Phi P Phi^T + Q``, symmetrised."""
    nxt = phi @ p @ phi.T + q
    return 0.5 * (nxt + nxt.T)


def _split_step(relinearize, m, p, t0: float, h: float, depth: int, cache: dict):
    """``propagate_linearized``'s step: ``(m, p, model)`` at ``t0 + h``."""
    start = relinearize(m, p)
    m1, p1 = _exact_step(start, m, p, t0, h, cache)
    middle = relinearize(0.5 * (m + m1), 0.5 * (p + p1))
    moved = np.abs(middle.a - start.a).max() / max(np.abs(start.a).max(), 1e-300)
    if moved > SPLIT and depth < DEPTH:
        for k in range(4):
            m, p, middle = _split_step(relinearize, m, p, t0 + k * h / 4, h / 4, depth + 1, cache)
        return m, p, middle
    if moved > SPLIT:
        raise NotApplicable("statistical linearisation moves faster than its steps can follow "
                            f"(the drift moved {moved:.0%} over a step of {h:.3g} s)")
    m2, p2 = _exact_step(middle, m, p, t0, h, cache)
    return m2, p2, middle


def _scale(row, t: float) -> float:
    """A noise column's envelope at ``t`` (1 for white noise): ``physics.loads.envelope``."""
    return 1.0 if row is None else float(envelope.py_func(t, row))
