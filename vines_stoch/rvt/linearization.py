"""Gaussian statistical linearisation of the absorber laws (MODEL.md section 6; Roberts and
Spanos, "Random Vibration and Statistical Linearization", Wiley 1990, ch. 5-6).

Absorber ``a``'s elastic force ``g(u)`` (its damping is linear) is replaced, under the Gaussian
law ``u ~ N(mu, s^2)`` of its motion relative to its host floor, by ``E[g] + k (u - mu)`` with the
slope ``k = E[g'(u)]``: closed forms for the polynomial laws (linear, cubic, bistable:
``E[y^3] = mu^3 + 3 mu s^2``) and Hertz contact (``E[z_+^p]`` of a Gaussian ``z`` by the parabolic
cylinder function ``D``: ``s^p Gamma(p + 1) exp(-m^2 / 4 s^2) D_{-p-1}(-m / s) / sqrt(2 pi)``) and the
gap spring (``-k (E[(y - g)_+] - E[(-y - g)_+])``, slope ``-k P(|y| > g)``), Gauss-Hermite
quadrature for the geometric law.  The moments depend on the slopes, so the pair is
iterated to a fixed point (``stationary``).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.special import gamma, pbdv

from ..physics.absorbers import (
    FREE_LENGTH,
    GAP,
    HERTZ,
    K_CUBIC,
    K_GAP,
    K_GEO,
    K_LEFT,
    K_LIN,
    K_RIGHT,
    LENGTH,
    REST,
    WALL_HI,
    WALL_LO,
    geometric_force,
)
from . import moments
from .system import Model, NotApplicable, bare, with_absorbers

#: Gauss-Hermite nodes (probabilists') of the geometric law's expectations.
NODES, WEIGHTS = np.polynomial.hermite_e.hermegauss(64)
WEIGHTS = WEIGHTS / math.sqrt(2.0 * math.pi)


def positive_moment(m: float, s: float, p: float) -> float:
    """``E[max(z, 0)^p]`` for ``z ~ N(m, s^2)`` (closed form: module docstring); for ``p = 0``
    the probability ``P(z > 0)``."""
    if s <= 0.0:
        return float(m > 0.0) if p == 0.0 else max(m, 0.0) ** p
    x = -m / s
    if x > 37.0:  # (no mass beyond zero left to double precision)
        return 0.0
    if x < -30.0:  # (all of it beyond zero: E[z^p] to second order; D would overflow)
        return m**p * (1.0 + 0.5 * p * (p - 1.0) / (x * x))
    d, _ = pbdv(-p - 1.0, x)
    return s**p * gamma(p + 1.0) * math.exp(-x * x / 4.0) * d / math.sqrt(2.0 * math.pi)


def law(row: np.ndarray, mu: float, s: float) -> tuple[float, float]:
    """``(E[g], E[g'])`` of an absorber row's elastic force (``physics.absorbers``, ``physics.hertz``)
    for the relative motion ``u ~ N(mu, s^2)``."""
    y = mu - row[REST]
    mean = -(row[K_LIN] * y + row[K_CUBIC] * (y**3 + 3.0 * y * s * s))
    slope = -(row[K_LIN] + 3.0 * row[K_CUBIC] * (y * y + s * s))
    if row[K_GEO] != 0.0:
        force = geometric_force.py_func
        values = np.array([force(y + s * n, row[K_GEO], row[FREE_LENGTH], row[LENGTH]) for n in NODES])
        mean += float(WEIGHTS @ values)
        if s > 0.0:
            slope += float(WEIGHTS @ (values * NODES)) / s  # (Stein: E[g'] = E[g (u - mu)] / s^2)
        else:
            e = 1e-7 * max(abs(y), row[LENGTH])
            slope += (force(y + e, row[K_GEO], row[FREE_LENGTH], row[LENGTH])
                      - force(y - e, row[K_GEO], row[FREE_LENGTH], row[LENGTH])) / (2.0 * e)
    if row[K_GAP] != 0.0:
        g = row[GAP]
        mean -= row[K_GAP] * (positive_moment(y - g, s, 1.0) - positive_moment(-y - g, s, 1.0))
        slope -= row[K_GAP] * (positive_moment(y - g, s, 0.0) + positive_moment(-y - g, s, 0.0))
    for k, sign, m in ((row[K_LEFT], 1.0, row[WALL_LO] - mu), (row[K_RIGHT], -1.0, mu - row[WALL_HI])):
        if k > 0.0:  # left: +K z_L^1.5, z_L = WALL_LO - u; right: -K z_R^1.5, z_R = u - WALL_HI
            mean += sign * k * positive_moment(m, s, 1.5)
            slope -= 1.5 * k * positive_moment(m, s, 0.5)
    return mean, slope


def contact_mean(row: np.ndarray, s: float) -> float:
    """The mean ``mu`` of a Hertz absorber's relative motion at which its mean force ``E[g]``
    vanishes, for the standard deviation ``s``: the absorber's mean balance (no mean load reaches
    it but through its attachment), with the contact's stiff mean force taken quasi-statically
    (a linearisation about any other mean overshoots across the contact; ``E[g]`` falls with
    ``mu``, so the root is one).  NotApplicable where none is found: a one-barrier absorber
    without a spring (seed 001 eq. 1) has nothing that pulls it back from the barrier."""
    from scipy.optimize import brentq

    def force(mu: float) -> float:
        return law(row, mu, s)[0]

    walls = [w for w in (row[WALL_LO], row[WALL_HI]) if math.isfinite(w)]  # (no left one: seed 001 eq. 1)
    width = max(s, max(walls) - min(walls), abs(row[REST]), 1e-12)
    lo, hi = min(*walls, row[REST]) - width, max(*walls, row[REST]) + width
    for _ in range(60):
        if force(lo) > 0.0 > force(hi):
            break
        lo, hi = lo - width, hi + width
        width *= 2.0
    else:
        raise NotApplicable("a Hertz absorber with nothing to pull it back on one side: no mean balance")
    return brentq(force, lo, hi, xtol=1e-15 * width, rtol=1e-12)


def settle(scene, mu: np.ndarray, s: np.ndarray) -> np.ndarray:
    """``mu`` with the Hertz absorbers' means at their quasi-static balance (``contact_mean``)."""
    mu = np.array(mu, dtype=float)
    for a in np.flatnonzero(scene.kind == HERTZ):
        mu[a] = contact_mean(scene.rows[a], float(s[a]))
    return mu


def coefficients(scene, mu: np.ndarray, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(slope, g0)`` of every absorber: ``g(u) ~ g0 + slope u`` with ``g0 = E[g] - slope mu``."""
    slope, g0 = np.empty(len(mu)), np.empty(len(mu))
    for a in range(len(mu)):
        mean, slope[a] = law(scene.rows[a], mu[a], s[a])
        g0[a] = mean - slope[a] * mu[a]
    return slope, g0


def strokes(model: Model, scene, m: np.ndarray, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mean and standard deviation of every absorber's motion relative to its host floor."""
    rows = np.array([model.x(model.n_floors + a) - model.x(scene.host[a]) for a in range(len(scene.kind))])
    rows = rows.reshape(-1, model.size)
    return rows @ m, np.sqrt(np.maximum(np.einsum("ai,ij,aj->a", rows, p, rows), 0.0))


def linearized(scene, filters: list, mu: np.ndarray, s: np.ndarray) -> Model:
    """The model of ``scene`` linearised at the absorbers' laws ``N(mu, s^2)`` (its bare structure
    built once a scene: ``_BARE``)."""
    key = (id(scene), id(filters))
    if key not in _BARE or _BARE[key][0] is not scene or _BARE[key][1] is not filters:
        _BARE.clear()
        _BARE[key] = (scene, filters, bare(scene, filters))
    return with_absorbers(_BARE[key][2], scene, *coefficients(scene, mu, s))


#: The bare model of the scene last linearised (the scene and filters kept: their ids stay theirs).
_BARE: dict = {}


#: Relative change of the strokes' moments at which the iteration stops, and its largest count.
TOLERANCE, ITERATIONS = 1e-9, 300


def stationary(scene, filters: list, mu: np.ndarray,
               s: np.ndarray) -> tuple[Model, np.ndarray, np.ndarray, int]:
    """The fixed point of statistical linearisation reached from ``(mu, s)``: ``(model, mean,
    covariance, iterations)``; NotApplicable where the iteration meets an unstable model or does
    not settle.  Each step moves the standard deviations a share of the way (geometrically) and the
    means linearly: half at most, halved while the change grows (a damped iteration: the cubic
    law's plain one oscillates, stiff contacts more so)."""
    step, last = 0.5, math.inf
    for count in range(1, ITERATIONS + 1):
        mu = settle(scene, mu, s)
        model = linearized(scene, filters, mu, s)
        p = moments.stationary_covariance(model)
        m = moments.constant_response(model)
        mu_new, s_new = strokes(model, scene, m, p)
        s_new = np.maximum(s_new, 1e-300)
        mu_new = settle(scene, mu_new, s_new)
        scale = max(float(np.max(s)), float(np.max(np.abs(mu))), 1e-300)
        change = max(float(np.max(np.abs(s_new - s))), float(np.max(np.abs(mu_new - mu)))) / scale
        if change < TOLERANCE:
            return model, m, p, count
        step = min(0.5, 1.5 * step) if change < last else max(step / 2.0, 1.0 / 256.0)
        last = change
        s, mu = s ** (1.0 - step) * s_new**step, (1.0 - step) * mu + step * mu_new
    raise NotApplicable(f"statistical linearisation did not settle in {ITERATIONS} iterations")
