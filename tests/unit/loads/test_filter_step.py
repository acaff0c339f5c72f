"""The exact step of a filtered load (``filters.transition``, MODEL.md section 3) for any
``|pole| dt``: its noise covariance ``Q(dt) = int_0^dt exp(A s) b b^T exp(A^T s) ds`` against
references that share nothing with the build.

- The Ornstein-Uhlenbeck filter: ``Q = b^2 (1 - exp(-2 p dt)) / (2 p)`` in closed form.
- The filtered-noise oscillator, Kanai-Tajimi, Clough-Penzien and the Davenport and Kaimal wind
  cascades: adaptive quadrature of ``g(s) g(s)^T``, ``g(s) = exp(A s) b`` (scipy's ``quad_vec``
  at a relative tolerance of 1e-12), and for the stable filters the stationary route
  ``P - Phi P Phi^T`` (``P`` from the Lyapunov equation) where ``Phi P Phi^T`` is under 1 % of
  ``P`` (no cancellation to speak of).

Errors are measured entry by entry relative to ``D_i D_j`` (``D`` the reference's standard
deviations, the bound a covariance entry has): a state whose variance is 1e12 times another's
(position against velocity over a short step) is held to the same relative accuracy.  The
references agree with an 80-digit evaluation to about 1e-14 in that measure; the build (Van
Loan's exponential at a small step, then doublings that add positive terms) to 3e-12 or
better; the tolerance 1e-9 leaves three decades for hosts' BLAS kernels.  Van Loan's
exponential over the whole step, which this build replaced, missed by 1e-4 at ``|pole| dt`` = 52
on the Clough-Penzien filter, by 1e218 at 1e3, and on some hosts by 4e4 on the Davenport
cascade at 52.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad_vec
from scipy.linalg import expm

from tests.unit.loads.test_wind import the_load
from vines_stoch.physics import filters
from vines_stoch.physics.filters import (
    clough_penzien,
    filtered_noise,
    kanai_tajimi,
    stationary_covariance,
    transition,
)
from vines_stoch.scene import wind_load

#: The ``|pole| dt`` of the largest pole, from a tiny step to a thousand time constants.
REACH = (1e-4, 1e-2, 0.5, 3.0, 52.0, 1e3)
TOLERANCE = 1e-9


def wind_filter(spectrum: str) -> tuple[np.ndarray, np.ndarray]:
    _, turbulence = wind_load(the_load(spectrum), 3)
    return turbulence.a, turbulence.b


FILTERS = {
    "filtered noise": lambda: filtered_noise(0.7, 2.0, 0.05)[:2],
    "kanai-tajimi": lambda: kanai_tajimi(0.3, 15.6, 0.6)[:2],
    "clough-penzien": lambda: clough_penzien(0.3, 15.6, 0.6, 1.6, 0.6)[:2],
    "davenport": lambda: wind_filter("davenport"),
    "kaimal": lambda: wind_filter("kaimal"),
}


def scaled_error(q: np.ndarray, reference: np.ndarray) -> float:
    d = np.sqrt(np.diag(reference))
    return float(np.max(np.abs(q - reference) / np.outer(d, d)))


def quadrature(a: np.ndarray, b: np.ndarray, dt: float) -> np.ndarray:
    """``int_0^dt g g^T ds`` by adaptive quadrature: the interval cut at multiples of the
    fastest time constant (a stiff filter's integrand lives near ``s = 0``) and ended where
    ``g g^T`` has decayed by ``exp(-50)`` (the rest is below the rounding of the sum); a first
    pass at 1e-6 gives the scales ``D`` of a second at 1e-12 on ``g g^T / (D_i D_j)`` (quad_vec's
    tolerance is on the largest entry: scaled, it holds for every entry)."""
    eigenvalues = np.linalg.eigvals(a)
    end = min(dt, 25.0 / np.min(-eigenvalues.real))
    cuts = [0.0] + [t for t in np.geomspace(1e-3, 1e3, 13) / np.max(np.abs(eigenvalues)) if t < end] + [end]

    def integral(weights: np.ndarray, rel: float) -> np.ndarray:
        def g(s: float) -> np.ndarray:
            x = (expm(a * s) @ b) / weights
            return np.outer(x, x)
        return sum(quad_vec(g, lo, hi, epsabs=0.0, epsrel=rel)[0] for lo, hi in zip(cuts[:-1], cuts[1:]))

    scales = np.sqrt(np.diag(integral(np.ones(len(b)), 1e-6)))
    return integral(scales, 1e-12) * np.outer(scales, scales)


@pytest.mark.parametrize("reach", REACH)
def test_ornstein_uhlenbeck_closed_form(reach):
    p, b = 3.0, 0.8
    dt = reach / p
    phi, root = transition(np.array([[-p]]), np.array([b]), dt)
    assert phi[0, 0] == pytest.approx(np.exp(-p * dt), rel=1e-14)
    exact = b**2 * -np.expm1(-2.0 * p * dt) / (2.0 * p)
    assert (root @ root.T)[0, 0] == pytest.approx(exact, rel=TOLERANCE)


@pytest.mark.parametrize("reach", REACH)
@pytest.mark.parametrize("name", FILTERS)
def test_step_covariance_against_quadrature_and_the_stationary_route(name, reach):
    a, b = FILTERS[name]()
    dt = reach / np.max(np.abs(np.linalg.eigvals(a)))
    phi, root = transition(a, b, dt)
    np.testing.assert_array_equal(phi, expm(a * dt))
    q = root @ root.T
    assert scaled_error(q, quadrature(a, b, dt)) < TOLERANCE
    p = stationary_covariance(a, b)
    kept = phi @ p @ phi.T
    if np.all(np.abs(np.diag(kept)) < 1e-2 * np.diag(p)):
        assert scaled_error(q, p - kept) < TOLERANCE


def test_the_check_refuses_a_covariance_off_the_identity():
    """The build's own check (symmetric, positive semi-definite, ``A Q + Q A^T + b b^T = Phi b
    b^T Phi^T``): the covariance one host's BLAS gave Van Loan's whole-step exponential on the
    Davenport cascade at ``|pole| dt`` = 52 (diagonal 6.8e6, 9.5e6, 5.7e4 where it is 182,
    1031, 1.03) is refused, and so is the true covariance one percent off."""
    a, b = wind_filter("davenport")
    dt = 52.0 / np.max(np.abs(np.linalg.eigvals(a)))
    phi, root = transition(a, b, dt)
    q = root @ root.T
    filters._check_covariance(a, b, phi, q, dt)  # the build's own passes
    blown = np.diag(np.sqrt(np.array([6.8e6, 9.5e6, 5.7e4]) / np.diag(q)))  # that diagonal
    for wrong in (blown @ q @ blown, 1.01 * q):
        with pytest.raises(FloatingPointError, match="failed its check"):
            filters._check_covariance(a, b, phi, wrong, dt)
