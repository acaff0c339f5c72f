"""Response-spectrum intensity measures of ground accelerations: the pseudo-spectral
acceleration ``Sa(T, zeta)`` and the peak ground acceleration.

``Sa = omega^2 max |u|`` with ``u`` the relative displacement of a linear oscillator of period
``T`` and damping ratio ``zeta`` from rest, ``u'' + 2 zeta omega u' + omega^2 u = -a_g``.  The
ground acceleration is taken piecewise linear between its samples, for which the state at the
samples follows exactly from the recursion ``X_{k+1} = Phi X_k + P a_k + Q a_{k+1}`` (Nigam and
Jennings, Bull. Seismol. Soc. Am. 59 (1969) 909; Chopra, *Dynamics of Structures*, section
5.2), its matrices from one matrix exponential.  With ``W_k = X_k - Q a_k`` it is the linear
filter ``W_{k+1} = Phi W_k + (Phi Q + P) a_k``, ``u_k = c W_k + c Q a_k``, run by
``scipy.signal.lfilter`` (no Python loop for a long record or an ensemble's paths); rest at
the first sample is ``W_0 = -Q a_0``, whose free response is added.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.linalg import expm
from scipy.signal import lfilter, ss2tf

#: Damping ratio of spectra unless given (the design-code convention).
DAMPING = 0.05


def uniform(times: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, float]:
    """A record on a uniform grid: its values and step where its times are uniform (to 1e-6
    of a step), else linearly interpolated on the grid of its smallest step."""
    steps = np.diff(times)
    if steps.size == 0:
        return values, 1.0
    dt = float(steps.min())
    if float(steps.max()) - dt <= 1e-6 * dt:
        return values, float(steps.mean())
    grid = np.arange(times[0], times[-1] + 0.5 * dt, dt)
    return np.interp(grid, times, values), dt


def displacement(ag: np.ndarray, dt: float, period: float, damping: float = DAMPING) -> np.ndarray:
    """Relative displacement at the samples of an oscillator of ``period`` (s) and ``damping``
    at rest at the first sample under the ground acceleration ``ag`` (samples ``dt`` apart,
    linear in between; a path a row where ``ag`` has two dimensions, each filtered on its own
    as a one-dimensional ``ag`` is, bitwise)."""
    ag = np.asarray(ag, dtype=float)
    omega = 2.0 * math.pi / period
    # exp of [[A, B, 0], [0, 0, 1/h], [0, 0, 0]] h: Phi, int e^{A(h-s)} B ds, int e^{A(h-s)} B s/h ds
    m = np.zeros((4, 4))
    m[:2, :2] = [[0.0, 1.0], [-omega**2, -2.0 * damping * omega]]
    m[1, 2] = -1.0
    m[2, 3] = 1.0 / dt
    e = expm(m * dt)
    phi, gamma0, gamma1 = e[:2, :2], e[:2, 2:3], e[:2, 3:4]
    p, q = gamma0 - gamma1, gamma1
    c = np.array([[1.0, 0.0]])
    num, den = ss2tf(phi, phi @ q + p, c, c @ q)
    u = lfilter(num[0], den, ag, axis=-1)
    moving = ag[..., 0] != 0.0 if ag.shape[-1] else np.zeros(ag.shape[:-1], bool)
    if np.any(moving):  # the free response of W_0 = -Q a_0 (of the paths not at rest)
        num0, _ = ss2tf(phi, -(phi @ q), c, -(c @ q))
        kick = np.zeros_like(ag[moving])
        kick[..., 0] = ag[moving][..., 0]
        u[moving] += lfilter(num0[0], den, kick, axis=-1)
    return u


def pseudo_acceleration(ag: np.ndarray, dt: float, period: float,
                        damping: float = DAMPING) -> float | np.ndarray:
    """``Sa(T, zeta) = omega^2 max |u|`` of the ground acceleration ``ag`` (its units; one a
    row where ``ag`` has two dimensions)."""
    omega = 2.0 * math.pi / period
    u = np.abs(displacement(ag, dt, period, damping))
    sa = omega**2 * u.max(axis=-1) if u.shape[-1] else np.zeros(u.shape[:-1])
    return float(sa) if np.ndim(sa) == 0 else sa


def peak(ag: np.ndarray) -> float | np.ndarray:
    """Peak ground acceleration ``max |a_g|`` (one a row where ``ag`` has two dimensions)."""
    ag = np.abs(np.asarray(ag, dtype=float))
    pga = ag.max(axis=-1) if ag.shape[-1] else np.zeros(ag.shape[:-1])
    return float(pga) if np.ndim(pga) == 0 else pga
