"""Crossings, first passage and peaks of a Gaussian response (MODEL.md section 6).

- Rice's rate of up-crossings of a level ``b`` by a Gaussian ``y`` of mean ``m``, variance
  ``s^2``, derivative mean ``m'`` and derivative variance ``s'^2``, correlation ``rho``:
  ``nu_b = phi((b - m) / s) / s * E[max(D, 0)]``, ``D ~ N(m' + rho s' (b - m) / s, s'^2 (1 - rho^2))``
  (Rice 1944-45; for a stationary zero-mean ``y``: ``s' / (2 pi s) exp(-b^2 / 2 s^2)``); the
  barrier ``|y| = b`` is crossed outwards at the rate of ``y`` up through ``b`` plus ``-y`` up
  through ``b``.
- Poisson: ``P_f = 1 - P(|y(t0)| <= b) exp(-int nu dt)``.
- Vanmarcke (J. Appl. Mech. 42 (1975) 215, DOI 10.1115/1.3423521): a zero-mean response's
  crossings come in clumps; its rate of first passages is the Poisson rate times
  ``(1 - exp(-sqrt(pi / 2) delta_e r)) / (1 - exp(-r^2 / 2))``, ``r = b / s``, ``delta_e =
  delta^1.2`` and ``delta = sqrt(1 - lambda_1^2 / (lambda_0 lambda_2))`` the bandwidth of the
  one-sided spectral moments ``lambda_i``.  It lies below Poisson's, most for narrow bands.
- The mean peak ``E[max |y|] = int_0^inf P(max |y| > b) db`` from the same law of first passage.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.special import ndtr

SQRT_2PI = math.sqrt(2.0 * math.pi)


def _positive_mean(mean: np.ndarray, sd: np.ndarray) -> np.ndarray:
    """``E[max(D, 0)]`` for ``D ~ N(mean, sd^2)``."""
    with np.errstate(divide="ignore", invalid="ignore"):
        x = np.where(sd > 0, mean / np.where(sd > 0, sd, 1.0), np.sign(mean) * np.inf)
        out = sd * np.exp(-0.5 * x * x) / SQRT_2PI + mean * ndtr(x)
    return np.where(sd > 0, out, np.maximum(mean, 0.0))


def upcrossing_rate(b, m, s, dm, ds, cov) -> np.ndarray:
    """Rice's rate of up-crossings of ``b`` (broadcast) by ``y``: mean ``m``, standard deviation
    ``s``, derivative mean ``dm`` and standard deviation ``ds``, ``cov = E[(y - m)(y' - dm)]``."""
    b, m, s, dm, ds, cov = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (b, m, s, dm, ds, cov)))
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        safe = np.where(s > 0, s, 1.0)
        z = (b - m) / safe
        cond_mean = dm + cov / safe * z
        cond_sd = np.sqrt(np.maximum(ds * ds - (cov / safe) ** 2, 0.0))
        density = np.exp(-0.5 * z * z) / (SQRT_2PI * safe)
        rate = density * _positive_mean(cond_mean, cond_sd)
    return np.where(s > 0, rate, 0.0)


def barrier_rate(b, m, s, dm, ds, cov) -> np.ndarray:
    """The rate of outward crossings of ``|y| = b``: ``y`` up through ``b`` and ``-y`` up through ``b``."""
    return (upcrossing_rate(b, m, s, dm, ds, cov)
            + upcrossing_rate(b, -np.asarray(m), s, -np.asarray(dm), ds, cov))


def vanmarcke_factor(r: np.ndarray, delta: float) -> np.ndarray:
    """Vanmarcke's factor on the Poisson rate of a zero-mean response at ``r = b / s`` standard
    deviations (module docstring): 1 for a broad band at high barriers, below 1 for narrow bands."""
    r = np.asarray(r, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        factor = -np.expm1(-math.sqrt(math.pi / 2.0) * delta**1.2 * r) / -np.expm1(-0.5 * r * r)
    return np.where(r > 0, factor, 1.0)


def bandwidth(omega: np.ndarray, one_sided: np.ndarray) -> float:
    """Vanmarcke's ``delta = sqrt(1 - lambda_1^2 / (lambda_0 lambda_2))`` of a one-sided spectrum
    on the grid ``omega`` (trapezoid rule)."""
    moments = [np.trapezoid(omega**i * one_sided, omega) for i in range(3)]
    return float(math.sqrt(max(0.0, 1.0 - moments[1] ** 2 / (moments[0] * moments[2]))))


def exceedance(t: np.ndarray, b: np.ndarray, stats: dict[str, np.ndarray], delta: float | None,
               start: float = 1.0) -> np.ndarray:
    """``P(max |y| > b)`` over the times ``t`` (trapezoid rule over the rates) for every barrier
    in ``b``: Poisson's (``delta`` None) or Vanmarcke's (zero-mean ``y``, bandwidth ``delta``);
    ``start``: multiply by ``P(|y(t0)| <= b)`` (``stats['s'][0]`` > 0) when 1."""
    b = np.asarray(b, dtype=float)[:, None]
    rate = barrier_rate(b, stats["m"][None], stats["s"][None], stats["dm"][None], stats["ds"][None],
                        stats["cov"][None])
    if delta is not None:
        with np.errstate(divide="ignore", invalid="ignore"):
            r = b / np.where(stats["s"][None] > 0, stats["s"][None], np.inf)
        rate = rate * vanmarcke_factor(r, delta)
    count = np.trapezoid(rate, t, axis=1) if len(t) > 1 else np.zeros(len(b))
    survive = np.exp(-count)
    if start and stats["s"][0] > 0:
        s0, m0 = stats["s"][0], stats["m"][0]
        survive = survive * (ndtr((b[:, 0] - m0) / s0) - ndtr((-b[:, 0] - m0) / s0))
    elif start:
        survive = survive * (np.abs(stats["m"][0]) <= b[:, 0])
    return 1.0 - survive


def mean_peak(t: np.ndarray, stats: dict[str, np.ndarray], delta: float | None, points: int = 64) -> float:
    """``E[max |y|]`` over the times ``t``: ``int_0^inf P(max |y| > b) db`` on ``points`` barriers up
    to 10 standard deviations beyond the largest ``|mean|``."""
    top = float(np.max(np.abs(stats["m"])) + 10.0 * np.max(stats["s"]))
    if top <= 0.0:
        return 0.0
    b = np.linspace(0.0, top, points)
    return float(np.trapezoid(exceedance(t, b, stats, delta), b))
