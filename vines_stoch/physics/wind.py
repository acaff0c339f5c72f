"""Along-wind load on a shear building (seed 001 section 3.7; README "Wind").

Quasi-steady, linearised along-wind force on floor ``k`` at height ``z_k`` with tributary
area ``A_k`` and drag coefficient ``Cd``, under the wind speed ``U(z_k) + u(t)``::

    F_k(t) = Fbar_k + f_k(t),   Fbar_k = 0.5 rho Cd A_k U(z_k)^2,   f_k = rho Cd A_k U(z_k) u(t)

The longitudinal turbulence ``u(t)`` is one Gaussian process, fully correlated over the height
(the ``P(z, t) = P(z) F(t)`` of seed 001); the quadratic term ``0.5 rho Cd A_k u^2`` is left out.
Its one-sided spectrum ``S(n)`` (``n`` in Hz) is Davenport's (1961) or Kaimal's (1972); both are
``S(n) = (sigma_u^2 / 6) T g(n T)`` with a time scale ``T`` and a reduced spectrum ``g`` of
integral 6 (so ``sigma_u^2`` is the variance):

- Davenport: ``T = 1200 m / U10``, ``g(x) = 4 x / (1 + x^2)^(4/3)``, ``sigma_u^2 = 6 kappa U10^2``;
- Kaimal: ``T = z / U(z)``, ``g(f) = 200 / (1 + 50 f)^(5/3)``, ``sigma_u^2 = 6 u*^2``.

``u(t)`` is realised as the output of a linear filter of order ``N`` (2 or 3) driven by white
noise, ``H(s) = G prod_{j<N} (s + z_j) / prod_{i<=N} (s + p_i)`` with real negative poles and
zeros: its reduced poles and zeros minimise the squared error of ``ln S`` over a band of
reduced frequency (least squares, once per spectrum, band and order), under the constraint
that the rational spectrum's variance is ``sigma_u^2`` exactly (``G`` follows from the
Lyapunov equation).  The filter is a cascade of first-order sections (lower-triangular drift),
well conditioned however far apart the poles lie.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

#: von Karman's constant (log law, default friction velocity of Kaimal's spectrum).
VON_KARMAN = 0.4
#: Davenport's length scale (m): ``x = 1200 n / U10``.
DAVENPORT_LENGTH = 1200.0
#: Davenport's surface drag coefficient of open country (``sigma_u^2 = 6 kappa U10^2``).
OPEN_COUNTRY_DRAG = 0.005
#: Default fitting bands in reduced frequency ``n T``: Davenport's ``x`` in [0.03, 300] holds
#: 97.8 % of the variance, Kaimal's ``f`` in [0.001, 10] 95.2 %.
BANDS = {"davenport": (0.03, 300.0), "kaimal": (1e-3, 10.0)}
#: Points of the log-spaced fitting grid.
GRID = 241


def reduced_spectrum(name: str, nu: np.ndarray) -> np.ndarray:
    """The reduced one-sided spectrum ``g(nu)`` (integral 6 over ``nu > 0``) of ``"davenport"``
    (``nu = x = 1200 n / U10``) or ``"kaimal"`` (``nu = f = n z / U(z)``)."""
    nu = np.asarray(nu, dtype=float)
    if name == "davenport":
        return 4.0 * nu / (1.0 + nu**2) ** (4.0 / 3.0)
    if name == "kaimal":
        return 200.0 / (1.0 + 50.0 * nu) ** (5.0 / 3.0)
    raise ValueError(f"spectrum {name!r}: must be 'davenport' or 'kaimal'")


def target_spectrum(name: str, n: np.ndarray, variance: float, time_scale: float) -> np.ndarray:
    """One-sided target spectrum ``S(n) = (variance / 6) T g(n T)`` (``n`` in Hz)."""
    return variance / 6.0 * time_scale * reduced_spectrum(name, np.asarray(n, dtype=float) * time_scale)


def variance_share(name: str, lo: float, hi: float) -> float:
    """The share of the target variance between reduced frequencies ``lo`` and ``hi`` (closed
    forms of the integrals of ``g``: ``1 - (1 + x^2)^(-1/3)``, ``1 - (1 + 50 f)^(-2/3)``)."""
    if name == "davenport":
        cdf = lambda x: 1.0 - (1.0 + x * x) ** (-1.0 / 3.0)  # noqa: E731
    else:
        cdf = lambda f: 1.0 - (1.0 + 50.0 * f) ** (-2.0 / 3.0)  # noqa: E731
    return cdf(hi) - cdf(lo)


def mean_speed(z: np.ndarray, speed: float, reference_height: float, profile: str, exponent: float,
               roughness: float) -> np.ndarray:
    """Mean wind speed at heights ``z``: power law ``U_ref (z / z_ref)^alpha`` or log law
    ``U_ref ln(z / z0) / ln(z_ref / z0)``."""
    z = np.asarray(z, dtype=float)
    if profile == "power":
        return speed * (z / reference_height) ** exponent
    return speed * np.log(z / roughness) / math.log(reference_height / roughness)


def cascade(zeros: np.ndarray, poles: np.ndarray,
            gain: float = 1.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(A, b, c)`` of ``H(s) = gain prod (s + zeros) / prod (s + poles)`` (``len(zeros) <
    len(poles)``, all positive): ``x0' = -p_0 x0 + gain w``, then sections ``(s + z_j) / (s +
    p_j)`` fed by the previous output, ``y_j = y_{j-1} + (z_j - p_j) x_j``; output ``c . x``."""
    n = len(poles)
    if not len(zeros) < n:
        raise ValueError("a strictly proper filter needs fewer zeros than poles")
    zeros = list(zeros) + [None] * (n - 1 - len(zeros))
    a = np.zeros((n, n))
    out = np.zeros(n)
    a[0, 0] = -poles[0]
    out[0] = 1.0
    for j in range(1, n):
        a[j] = out
        a[j, j] = -poles[j]
        if zeros[j - 1] is None:  # a plain pole: y_j = x_j
            out = np.zeros(n)
            out[j] = 1.0
        else:
            out = out.copy()
            out[j] += zeros[j - 1] - poles[j]
    b = np.zeros(n)
    b[0] = gain
    return a, b, out


def rational_spectrum(a: np.ndarray, b: np.ndarray, c: np.ndarray, n: np.ndarray) -> np.ndarray:
    """One-sided spectrum (per Hz) of ``c . z`` for ``dz = A z dt + b dW``: ``2 |c (i w - A)^-1
    b|^2`` at ``w = 2 pi n`` (two-sided ``|H|^2 / (2 pi)`` per rad/s)."""
    n = np.atleast_1d(np.asarray(n, dtype=float))
    resolvent = 2j * np.pi * n[:, None, None] * np.eye(a.shape[0]) - a
    inputs = np.broadcast_to(b.astype(complex), (n.size, b.size))[..., None]
    h = np.linalg.solve(resolvent, inputs)[..., 0] @ c
    return 2.0 * np.abs(h) ** 2


def _variance(zeros: np.ndarray, poles: np.ndarray) -> float:
    """Variance of the unit-gain cascade's output under unit white noise (Lyapunov)."""
    from .filters import stationary_covariance

    a, b, c = cascade(zeros, poles)
    return float(c @ stationary_covariance(a, b) @ c)


def _unit_log_spectrum(zeros: np.ndarray, poles: np.ndarray, w2: np.ndarray) -> np.ndarray:
    """``ln (2 |H(i w)|^2)`` of the unit-gain cascade at ``w^2 = w2``."""
    num = sum(np.log(w2 + z * z) for z in zeros) if len(zeros) else 0.0
    return math.log(2.0) + num - sum(np.log(w2 + p * p) for p in poles)


@lru_cache(maxsize=64)
def rational_fit(name: str, lo: float, hi: float,
                 order: int = 3) -> tuple[tuple[float, ...], tuple[float, ...], float]:
    """Reduced zeros and poles (angular, per unit reduced time ``t / T``) of the rational
    approximation of order ``order`` to the reduced spectrum ``name`` over reduced frequencies
    ``[lo, hi]``, with its variance held at the target's (6), and the largest ``|ln(rational /
    target)|`` on the fitting grid.  Two starts (zero below or above the lowest pole), the
    better one is kept."""
    from scipy.optimize import least_squares

    nu = np.geomspace(lo, hi, GRID)
    w2 = (2.0 * np.pi * nu) ** 2
    target = np.log(reduced_spectrum(name, nu))
    nz = order - 1

    def split(theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        roots = np.exp(theta)
        return roots[:nz], roots[nz:]

    def residual(theta: np.ndarray) -> np.ndarray:
        zeros, poles = split(theta)
        return math.log(6.0 / _variance(zeros, poles)) + _unit_log_spectrum(zeros, poles, w2) - target

    w_lo, w_hi = 2.0 * np.pi * lo, 2.0 * np.pi * hi
    bounds = (math.log(w_lo / 100.0), math.log(w_hi * 100.0))
    best = None
    for zero_first in (False, True):
        roots = np.log(np.geomspace(w_lo * 3.0, w_hi / 3.0, 2 * order - 1))
        at = np.arange(0, 2 * nz, 2) + (0 if zero_first else 1)  # z p z p p, or p z p z p
        start = np.concatenate([roots[at], np.delete(roots, at)])
        try:
            fit = least_squares(residual, start, bounds=bounds, x_scale=1.0, xtol=1e-12, ftol=1e-12)
        except (ValueError, np.linalg.LinAlgError):
            continue
        if best is None or fit.cost < best.cost:
            best = fit
    if best is None:
        raise ValueError(f"no rational fit of the {name} spectrum over [{lo:g}, {hi:g}]")
    zeros, poles = split(best.x)
    error = float(np.max(np.abs(residual(best.x))))
    return tuple(sorted(zeros)), tuple(sorted(poles)), error


def turbulence_filter(name: str, variance: float, time_scale: float, band: tuple[float, float],
                      order: int = 3) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """``(A, b, c, error)``: the filter ``dz = A z dt + b dW`` whose output ``u = c . z`` has
    the rational spectrum fitted to ``name`` over ``band`` (Hz) and variance ``variance``
    exactly; ``error`` is the fit's largest ``|ln(rational / target)|`` on the band."""
    from .filters import stationary_covariance

    lo, hi = band[0] * time_scale, band[1] * time_scale
    zeros, poles, error = rational_fit(name, float(lo), float(hi), order)
    a, b, c = cascade(np.array(zeros) / time_scale, np.array(poles) / time_scale)
    unit = float(c @ stationary_covariance(a, b) @ c)
    return a, b * math.sqrt(variance / unit), c, error
