"""Linear filters that turn white noise into coloured loads (MODEL.md section 3).

Each filtered load is a small linear SDE ``dz = A z dt + b e(t) dW`` with one Wiener process
``W`` of its own and an amplitude envelope ``e(t)``; the load is a linear read-out of ``z``:
a force on a floor (``filtered-noise``, Wei et al. eq. 23) or a ground acceleration
(``ground-motion``: Kanai-Tajimi, Clough-Penzien).

Kernels advance the filter states by the exact Gaussian transition of a step,
``z(t + dt) = Phi z(t) + e(t + dt/2) L n`` with ``Phi = exp(A dt)``, ``L L^T`` the covariance
``Q(dt) = int_0^dt exp(A s) b b^T exp(A^T s) ds`` and ``n`` standard normals, so the
filtered load has its exact law on the grid whatever ``dt``.

``Q(dt)`` is built by scaling and squaring: Van Loan's block exponential (Van Loan 1978, IEEE
Trans. Autom. Control 23(3), DOI 10.1109/TAC.1978.1101743) at ``h = dt / 2^k`` with
``||A h||_1 <= 1/2``, then ``k`` doublings ``Q(2h) = Q(h) + Phi(h) Q(h) Phi(h)^T``.  The
doublings add positive semi-definite terms, so nothing cancels and ``Q`` keeps its relative
accuracy for any ``|pole| dt``; Van Loan's exponential at the whole ``dt`` holds entries near
``exp(|pole| dt)`` and leaves ``Q`` to the rounding of their difference (at ``|pole| dt`` about
50 that rounding is larger than ``Q`` and depends on the host's BLAS kernels).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import expm, solve_continuous_lyapunov

from .loads import ENVELOPE_COLUMNS, ENVELOPE_FIRST


@dataclass(frozen=True)
class Filter:
    """One filtered load: ``dz = A z dt + b e(t) dW``, load ``= c . z`` (on the floor ``floor``,
    or ``profile[k] c . z`` on every floor ``k`` with a ``profile``)."""

    a: np.ndarray          # (n, n) drift matrix
    b: np.ndarray          # (n,) noise input
    c: np.ndarray          # (n,) read-out: force on a floor or ground acceleration
    ground: bool           # True: the read-out is a ground acceleration
    envelope: tuple        # (kind, p1, p2, p3), kinds of kernels/loads.py
    stationary: bool       # start from the stationary law
    floor: int = 0         # the floor (index) a force read-out acts on
    profile: np.ndarray | None = None  # (n_floors,) force read-out on every floor k: profile[k] c (wind)


def oscillator(frequency: float, damping: float) -> np.ndarray:
    """Drift matrix of ``y'' + 2 damping frequency y' + frequency^2 y``, state ``(y, y')``."""
    return np.array([[0.0, 1.0], [-frequency**2, -2.0 * damping * frequency]])


def filtered_noise(intensity: float, frequency: float,
                   damping: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Wei et al. eq. 23: ``f'' + 2 eta w0 f' + w0^2 f = sigma xi``; the force is ``f``."""
    return oscillator(frequency, damping), np.array([0.0, intensity]), np.array([1.0, 0.0])


def kanai_tajimi(intensity: float, wg: float, zg: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Kanai-Tajimi: ``y'' + 2 zg wg y' + wg^2 y = -w``; ground acceleration
    ``a_g = y'' + w = -(2 zg wg y' + wg^2 y)``, ``w dt = intensity dW``."""
    a = oscillator(wg, zg)
    return a, np.array([0.0, -intensity]), a[1].copy()


def clough_penzien(intensity: float, wg: float, zg: float, wf: float,
                   zf: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Clough-Penzien: the Kanai-Tajimi acceleration ``a1`` drives a high-pass oscillator
    ``p'' + 2 zf wf p' + wf^2 p = a1``; the ground acceleration is ``a_g = p''``."""
    kt, b, c1 = kanai_tajimi(intensity, wg, zg)
    a = np.zeros((4, 4))
    a[:2, :2] = kt
    a[2, 3] = 1.0
    a[3, :2] = c1
    a[3, 2:] = oscillator(wf, zf)[1]
    return a, np.concatenate([b, [0.0, 0.0]]), a[3].copy()


#: Largest ``||A h||_1`` of the step at which Van Loan's block exponential is evaluated.
VAN_LOAN_NORM = 0.5
#: Largest componentwise residual of the covariance check (``_check_covariance``) accepted, as a
#: fraction of the magnitudes of its terms (the rounding of the build is about 1e-15 of them).
COVARIANCE_CHECK = 1e-9


def transition(a: np.ndarray, b: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """``(Phi, L)``: the exact one-step transition matrix and a square root of the step's
    noise covariance ``Q(dt)`` (scaling and squaring of Van Loan's block exponential, module
    docstring), checked against the identity ``A Q + Q A^T + b b^T = Phi b b^T Phi^T``."""
    cov = step_covariance(a, np.outer(b, b), dt)
    phi = expm(a * dt)
    _check_covariance(a, b, phi, cov, dt)
    return phi, _sqrt_psd(cov)


def step_covariance(a: np.ndarray, bb: np.ndarray, dt: float) -> np.ndarray:
    """``Q(dt) = int_0^dt exp(A s) bb exp(A^T s) ds`` by scaling and squaring of Van Loan's block
    exponential (module docstring), unchecked (``transition`` checks it)."""
    n = a.shape[0]
    norm = float(np.linalg.norm(a, 1)) * dt
    k = int(np.ceil(np.log2(norm / VAN_LOAN_NORM))) if norm > VAN_LOAN_NORM else 0
    block = np.zeros((2 * n, 2 * n))
    block[:n, :n] = -a
    block[:n, n:] = bb
    block[n:, n:] = a.T
    e = expm(block * (dt / 2**k))
    step = e[n:, n:].T  # Phi(h)
    cov = _symmetric(step @ e[:n, n:])
    for _ in range(k):
        cov = _symmetric(cov + step @ cov @ step.T)
        step = step @ step
    return cov


def _symmetric(m: np.ndarray) -> np.ndarray:
    return 0.5 * (m + m.T)


def _check_covariance(a: np.ndarray, b: np.ndarray, phi: np.ndarray, cov: np.ndarray, dt: float) -> None:
    """Refuse a step covariance that is not symmetric positive semi-definite or breaks
    ``A Q + Q A^T + b b^T - (Phi b)(Phi b)^T = 0`` (``dQ/dt`` two ways) by more than
    ``COVARIANCE_CHECK`` of its terms' magnitudes entry by entry (``|Q_ij|`` bounded by
    ``D_i D_j``, ``D`` the standard deviations)."""
    pb = phi @ b
    residual = a @ cov + cov @ a.T + np.outer(b, b) - np.outer(pb, pb)
    d = _scales(cov)
    bound = np.outer(d, d)  # |Q_ij| <= D_i D_j for a covariance
    scale = (np.abs(a) @ bound + bound @ np.abs(a).T + np.outer(np.abs(b), np.abs(b))
             + np.outer(np.abs(pb), np.abs(pb)))
    lowest = np.linalg.eigvalsh(cov / bound)[0] if cov.size else 0.0
    bad = np.abs(residual) > COVARIANCE_CHECK * scale
    if not np.all(np.isfinite(cov)) or bad.any() or lowest < -COVARIANCE_CHECK:
        poles = np.abs(np.linalg.eigvals(a))
        raise FloatingPointError(
            f"filter step covariance failed its check at dt = {dt:g} (largest |pole| dt = "
            f"{poles.max() * dt:.3g}): lowest correlation eigenvalue {lowest:.3g}, "
            f"{int(bad.sum())} entries off the identity A Q + Q A^T + b b^T = Phi b b^T Phi^T")


def stationary_covariance(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Solution ``P`` of the Lyapunov equation ``A P + P A^T + b b^T = 0``."""
    return solve_continuous_lyapunov(a, -np.outer(b, b))


def _scales(cov: np.ndarray) -> np.ndarray:
    """Square roots of the diagonal of ``cov`` (1 where it is not positive)."""
    d = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    return np.where(d > 0.0, d, 1.0)


def _sqrt_psd(cov: np.ndarray) -> np.ndarray:
    """A matrix ``L`` with ``L L^T = cov`` for a symmetric positive semi-definite ``cov``, from
    the eigen-decomposition of its correlation matrix ``D^-1 cov D^-1`` (``D`` the standard
    deviations): every entry of ``L L^T`` is right to rounding relative to ``D_i D_j``, however
    far apart the variances lie (position and velocity of a stiff filter over a short step)."""
    d = _scales(cov)
    w, q = np.linalg.eigh(cov / np.outer(d, d))
    return d[:, None] * (q * np.sqrt(np.clip(w, 0.0, None)))


def block_diagonal(filters: list[Filter], dt: float, n_floors: int = 1) -> dict[str, np.ndarray]:
    """Kernel arrays of all filtered loads, stacked block-diagonally: ``phi``, ``chol``
    (step transition and noise root), ``envelope`` (one row per state: ``loads.ENVELOPE_COLUMNS``),
    ``c_force`` (one
    read-out row per floor; a filter with a ``profile`` reads out on every floor) and
    ``c_ground`` (one row), ``p0`` (root of the stationary covariance, zero for filters that
    start from rest)."""
    n = sum(f.a.shape[0] for f in filters)
    arrays = {name: np.zeros((n, n)) for name in ("phi", "chol", "p0")}
    arrays.update(envelope=np.zeros((n, ENVELOPE_COLUMNS)), c_force=np.zeros((n_floors, n)),
                  c_ground=np.zeros((1, n)))
    k = 0
    for f in filters:
        m = f.a.shape[0]
        s = slice(k, k + m)
        arrays["phi"][s, s], arrays["chol"][s, s] = transition(f.a, f.b, dt)
        if f.stationary:
            arrays["p0"][s, s] = _sqrt_psd(stationary_covariance(f.a, f.b))
        arrays["envelope"][s, :ENVELOPE_FIRST] = f.envelope
        arrays["envelope"][k, ENVELOPE_FIRST] = 1.0
        if f.ground:
            arrays["c_ground"][0, s] = f.c
        elif f.profile is not None:
            if np.shape(f.profile) != (n_floors,):
                raise ValueError(f"filter profile: {np.shape(f.profile)} values for {n_floors} floors")
            arrays["c_force"][:, s] = np.outer(f.profile, f.c)
        else:
            arrays["c_force"][f.floor, s] = f.c
        k += m
    return arrays
