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
class Path:
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
    to the constant forcing (``expm`` of the augmented drift) and the covariance of the noise
    columns of each envelope (``physics.filters.step_covariance``: Van Loan's exponential by
    scaling and squaring)."""
    n = model.size
    block = np.zeros((n + 1, n + 1))
    block[:n, :n] = model.a
    block[:n, n] = model.constant
    e = expm(block * h)
    groups: dict = {}
    for j, row in enumerate(model.envelopes):
        key = None if row is None or row[0] == STATIONARY else tuple(row)
        groups.setdefault(key, []).append(j)
    qs = [(key, step_covariance(model.a, model.noise[:, cols] @ model.noise[:, cols].T, h))
          for key, cols in groups.items()]
    return e[:n, :n], e[:n, n], qs


#: Largest change of the drift (relative to its largest entry) over which a relinearised step
#: keeps the transition of the last model it was computed for.
MOVED = 1e-4


def propagate(model: Model, t_end: float, steps: int,
              relinearize: Callable[[np.ndarray, np.ndarray], Model] | None = None) -> Path:
    """Means and covariances from the scene's start (``model.m0``, ``model.p0``) at ``steps + 1``
    times over ``[0, t_end]``.  Linear: one model, exact at the grid's times (harmonic forces by
    their steady response plus the free decay of the difference).  ``relinearize(m, P)``: the
    model at the current moments (statistical linearisation), taken at the start of each step (its
    transition computed afresh where its drift moved by more than ``MOVED``)."""
    h = t_end / steps
    t = np.linspace(0.0, t_end, steps + 1)
    amplitudes = harmonic_amplitudes(model) if model.harmonics else []
    if amplitudes and relinearize is not None:
        raise NotApplicable("harmonic forces on a nonlinear absorber: no combined linearisation here")
    steady0 = sum((x.real for _, x in amplitudes), np.zeros(model.size))
    m = np.empty((steps + 1, model.size))
    p = np.empty((steps + 1, model.size, model.size))
    m[0], p[0] = model.m0 - steady0, model.p0
    current, matrices, models = model, _step_matrices(model, h), [model]
    taken = model.a
    for i in range(steps):
        if relinearize is not None and i > 0:
            current = relinearize(m[i], p[i])
            if np.abs(current.a - taken).max() > MOVED * np.abs(taken).max() or (
                    current.constant != models[-1].constant).any():
                matrices, taken = _step_matrices(current, h), current.a
            models.append(current)
        phi, forced, qs = matrices
        m[i + 1] = phi @ m[i] + forced
        q = sum((_scale(key, t[i] + 0.5 * h) ** 2 * cov for key, cov in qs), np.zeros_like(phi))
        nxt = phi @ p[i] @ phi.T + q
        p[i + 1] = 0.5 * (nxt + nxt.T)
    for w, x in amplitudes:
        m += np.real(np.exp(1j * w * t)[:, None] * x[None, :])
    return Path(t, m, p, models)


def _scale(row, t: float) -> float:
    """A noise column's envelope at ``t`` (1 for white noise): ``physics.loads.envelope``."""
    return 1.0 if row is None else float(envelope.py_func(t, row))
