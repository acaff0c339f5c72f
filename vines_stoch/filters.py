"""Linear filters that turn white noise into coloured loads (MODEL.md section 3).

Each filtered load is a small linear SDE ``dz = A z dt + b e(t) dW`` with one Wiener process
``W`` of its own and an amplitude envelope ``e(t)``; the load is a linear read-out of ``z``:
a force on a floor (``filtered-noise``, Wei et al. eq. 23) or a ground acceleration
(``ground-motion``: Kanai-Tajimi, Clough-Penzien).

Kernels advance the filter states by the exact Gaussian transition of a step,
``z(t + dt) = Phi z(t) + e(t + dt/2) L n`` with ``Phi = exp(A dt)``, ``L L^T`` the covariance
``int_0^dt exp(A s) b b^T exp(A^T s) ds`` (Van Loan) and ``n`` standard normals, so the
filtered load has its exact law on the grid whatever ``dt``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import expm, solve_continuous_lyapunov


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


def transition(a: np.ndarray, b: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """``(Phi, L)``: the exact one-step transition matrix and a square root of the step's
    noise covariance (Van Loan's block exponential)."""
    n = a.shape[0]
    block = np.zeros((2 * n, 2 * n))
    block[:n, :n] = -a
    block[:n, n:] = np.outer(b, b)
    block[n:, n:] = a.T
    e = expm(block * dt)
    phi = e[n:, n:].T
    cov = phi @ e[:n, n:]
    cov = 0.5 * (cov + cov.T)
    return phi, _sqrt_psd(cov)


def stationary_covariance(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Solution ``P`` of the Lyapunov equation ``A P + P A^T + b b^T = 0``."""
    return solve_continuous_lyapunov(a, -np.outer(b, b))


def _sqrt_psd(cov: np.ndarray) -> np.ndarray:
    """A matrix ``L`` with ``L L^T = cov`` for a symmetric positive semi-definite ``cov``."""
    w, q = np.linalg.eigh(cov)
    return q * np.sqrt(np.clip(w, 0.0, None))


def block_diagonal(filters: list[Filter], dt: float, n_floors: int = 1) -> dict[str, np.ndarray]:
    """Kernel arrays of all filtered loads, stacked block-diagonally: ``phi``, ``chol``
    (step transition and noise root), ``envelope`` (one row per state), ``c_force`` (one
    read-out row per floor; a filter with a ``profile`` reads out on every floor) and
    ``c_ground`` (one row), ``p0`` (root of the stationary covariance, zero for filters that
    start from rest)."""
    n = sum(f.a.shape[0] for f in filters)
    arrays = {name: np.zeros((n, n)) for name in ("phi", "chol", "p0")}
    arrays.update(envelope=np.zeros((n, 4)), c_force=np.zeros((n_floors, n)), c_ground=np.zeros((1, n)))
    k = 0
    for f in filters:
        m = f.a.shape[0]
        s = slice(k, k + m)
        arrays["phi"][s, s], arrays["chol"][s, s] = transition(f.a, f.b, dt)
        if f.stationary:
            arrays["p0"][s, s] = _sqrt_psd(stationary_covariance(f.a, f.b))
        arrays["envelope"][s] = f.envelope
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
