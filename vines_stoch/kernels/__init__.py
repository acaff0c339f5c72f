"""Numba step loops, specialised to what a scene contains (noise, impacts, contact) and
compiled once.

``simulate(scene, generator)`` runs one realisation and returns the raw metric vector
(``common.SLOTS``).  Kernels are memoised by scene structure (the number of bodies
included); the parameters are arguments, so a sweep of parameters never recompiles.
"""

from __future__ import annotations

import numpy as np

from .common import POINCARE_SAMPLES, SLOTS, new_metrics
from .loads import load_path
from .rk4 import rk4_kernel
from .sie import sie_kernel

_NO_NORMALS = np.zeros(0)
_NO_HISTORY = np.zeros((0, 2))


def kernel_for(scene, replay: bool = False):
    """The compiled loop for a scene's scheme and structure."""
    piecewise, ground = scene.kernel_flags
    if scene.scheme == "rk4":
        return rk4_kernel(scene.mass.shape[0], scene.has_impact, scene.has_hertz, scene.period > 0, piecewise)
    return sie_kernel(scene.mass.shape[0], scene.forces.shape[0], scene.sigma > 0.0, scene.has_impact,
                      scene.filters["phi"].shape[0] > 0, piecewise, ground, replay, scene.scheme == "sra")


def sample_buffer(scene) -> np.ndarray:
    """Empty Poincare sample rows (positions, velocities, impacts left and right)."""
    if scene.period <= 0:
        return np.empty((0, 2 * scene.mass.shape[0] + 2))
    return np.full((POINCARE_SAMPLES, 2 * scene.mass.shape[0] + 2), np.nan)


def filter_tuple(scene, generator: np.random.Generator | None) -> tuple:
    """The kernels' filter arrays with the initial filter state: zero (from rest) or a draw
    from the stationary law (``p0`` is the root of its covariance)."""
    f = scene.filters
    z = np.zeros(f["phi"].shape[0])
    if z.shape[0] and f["p0"].any():
        z = f["p0"] @ generator.standard_normal(z.shape[0])
    return f["phi"], f["chol"], f["envelope"], f["c_force"], f["c_ground"], z


def _generator_for(scene, replay: bool, generator: np.random.Generator | None) -> np.random.Generator | None:
    """The generator a kernel draws from, or ``None`` where it draws nothing (white noise
    replayed without impacts, no noise at all): numba's unboxing of a Generator costs about
    6 us a call, half the set-up of a short run."""
    if not scene.has_noise or replay and not scene.has_impact:  # (replay refuses filtered loads)
        return None
    if generator is None:
        raise ValueError("generator: this scene draws random numbers (white or filtered noise, or the "
                         "Brownian-bridge draws of impacts under replayed noise); pass a numpy Generator")
    return generator


def simulate(scene, generator: np.random.Generator | None = None, *, normals: np.ndarray | None = None,
             final: np.ndarray | None = None, samples: np.ndarray | None = None,
             history: np.ndarray | None = None, stride: int = 1) -> np.ndarray:
    """Run one realisation of ``scene``; returns the raw metric vector (see ``SLOTS``).

    ``generator`` is required where the scene draws random numbers (a ``ValueError`` says so);
    ``normals`` replays a given Brownian path (one standard normal per step, two with the
    ``sra`` scheme: see ``sie_kernel``) instead of
    drawing from ``generator``; ``final`` (shape ``(2, n_bodies)``) receives the final
    positions and velocities; ``samples`` (from ``sample_buffer``) receives the Poincare
    samples of periodic scenes; ``history`` (shape ``(G, 2)``) receives ``x1`` and ``E1`` at
    ``t = j stride dt``, ``j < G`` (rows after a divergence keep their previous content).
    """
    out = new_metrics()
    x, v = scene.x0.copy(), scene.v0.copy()
    if samples is None:
        samples = sample_buffer(scene)
    replay = normals is not None
    needed = scene.n_steps * (2 if scene.scheme == "sra" else 1)
    if replay and normals.shape[0] < needed:
        raise ValueError(f"normals: need {needed} values, got {normals.shape[0]}")
    if replay and scene.filters["phi"].shape[0]:
        raise ValueError("normals: a replayed Brownian path drives white noise only, not filtered loads")
    kernel_for(scene, replay)(
        scene.mass, scene.k1, scene.c1, scene.k_lin, scene.k_cubic, scene.c_abs, scene.rest,
        scene.impact_body, scene.clearance, scene.restitution, scene.hertz_body, scene.hertz_k,
        scene.hertz_walls, scene.excitation, filter_tuple(scene, generator), scene.sigma, x, v,
        scene.dt, scene.n_steps, scene.i0,
        scene.period, scene.sample_from, _generator_for(scene, replay, generator),
        normals if replay else _NO_NORMALS, out, samples,
        _NO_HISTORY if history is None else history, stride,
    )
    if final is not None:
        final[0], final[1] = x, v
    return out


def load_history(scene, generator: np.random.Generator | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One sample path of a scene's loads on its time grid: ``(t, force on the primary,
    ground acceleration)``; filtered loads start from the same law and take the same exact
    steps as in the step loops (white noise, having no path value, is left out); ``generator``
    draws the filter states (default: a generator seeded with 0)."""
    n = scene.n_steps
    force, ground = np.zeros(n + 1), np.zeros(n + 1)
    gen = generator if generator is not None else np.random.default_rng(0)
    load_path(scene.excitation, filter_tuple(scene, gen), scene.dt, n, gen, force, ground)
    return scene.dt * np.arange(n + 1), force, ground


__all__ = ["SLOTS", "kernel_for", "load_history", "sample_buffer", "simulate"]
