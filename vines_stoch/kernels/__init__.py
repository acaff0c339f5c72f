"""Numba step loops, specialised to what a scene contains (noise, impacts) and compiled once.

``simulate(scene, generator)`` runs one realisation and returns the raw metric vector
(``common.SLOTS``).  Kernels are memoised by scene structure; the parameters are arguments,
so a sweep never recompiles.
"""

from __future__ import annotations

import numpy as np

from .common import SLOTS, new_metrics
from .rk4 import rk4_kernel
from .sie import sie_kernel

#: A generator handed to kernels of scenes without noise (never drawn from).
_NO_NOISE = np.random.default_rng(0)


def kernel_for(scene):
    """The compiled loop for a scene's scheme and structure."""
    if scene.scheme == "rk4":
        return rk4_kernel(scene.has_impact)
    return sie_kernel(scene.has_noise, scene.has_impact)


def simulate(scene, generator: np.random.Generator | None = None) -> np.ndarray:
    """Run one realisation of ``scene``; returns the raw metric vector (see ``SLOTS``)."""
    out = new_metrics()
    kernel_for(scene)(
        scene.mass, scene.k1, scene.c1, scene.k_lin, scene.k_cubic, scene.c_abs,
        scene.impact_body, scene.clearance, scene.restitution, scene.harmonic, scene.sigma,
        scene.x0, scene.v0, scene.dt, scene.n_steps, scene.i0,
        generator if generator is not None else _NO_NOISE, out,
    )
    return out


__all__ = ["SLOTS", "kernel_for", "simulate"]
