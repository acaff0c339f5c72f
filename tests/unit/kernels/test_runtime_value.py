"""``jit.intrinsics.runtime_value``: constants passed to an out-of-line function as run-time values, so
that it compiles once (``rk4.wall_accelerations``)."""

from __future__ import annotations

import numpy as np
from numba import njit

from tests.helpers import scene_from
from vines_stoch.jit.intrinsics import runtime_value
from vines_stoch.kernels.rk4 import HERTZ_FORCES, STICKING, _wall_accelerations, wall_accelerations
from vines_stoch.physics.absorbers import WALL_LO


@njit
def _typed(value):
    return value


@njit
def _literal_then_plain():
    return _typed(3) + _typed(runtime_value(4)) + _typed(runtime_value(True))


def test_a_constant_reaches_a_call_as_a_plain_value():
    assert _literal_then_plain() == 8
    kinds = sorted(str(sig[0]) for sig in _typed.signatures)
    assert kinds == ["Literal[int](3)", "bool", "int64"]  # the literal one is the call without


#: Two storeys; a Hertz absorber on the first floor pressed into its left wall and an impact
#: absorber stuck to the roof's right wall (its constraint checked with ``release``).
BUILDING = {
    "name": "wall accelerations",
    "primary": {"masses": [1.0, 0.8], "stiffnesses": [2.0, 1.5], "dampings": [0.02, 0.01]},
    "absorbers": [
        {"type": "hertz", "geometry": "double-sided", "floor": 1, "mass": 0.05, "stiffness": 0.2,
         "damping": 0.01, "offset": 0.0, "gap": 0.02, "contact_left": {"k": 1e4},
         "contact_right": {"k": 1e4}},
        {"type": "impact", "floor": 2, "mass": 0.04, "clearance": 0.02, "restitution": 0.5},
    ],
    "loads": [{"type": "harmonic", "amplitude": 0.3, "frequency": 1.1}],
    "simulation": {"duration": 1.0, "dt": 1e-3},
}


@njit
def _at_the_wall(x, v, mass, inv_mass, storey_k, storey_c, floor_c, kind, host, rows, ex, stuck, out):
    """Both calls of the RK4 loop, each with its literal floor count and flags."""
    forces, series_t, series_v, series_ptr, series_target = ex
    load, gm, gs = np.zeros(2), np.zeros(2), np.zeros(2)
    wall_accelerations(x, v, 0.3, 2, mass, inv_mass, storey_k, storey_c, floor_c, kind, host, host, rows,
                       forces, series_t, series_v, series_ptr, series_target, stuck, False, out[0], load, gm,
                       gs, STICKING | HERTZ_FORCES)
    wall_accelerations(x, v, 0.3, 2, mass, inv_mass, storey_k, storey_c, floor_c, kind, host, host, rows,
                       forces, series_t, series_v, series_ptr, series_target, stuck, True, out[1], load, gm,
                       gs, STICKING)


def test_the_wall_accelerations_compile_once():
    """Called with two literal sets of flags, the out-of-line body has one signature, of plain
    types; the two calls give two finite sets of accelerations."""
    scene = scene_from(BUILDING)
    x = np.array([0.01, -0.02, 0.0, -0.02 + 0.02])  # the impact absorber at the roof's right wall
    x[2] = x[0] + scene.rows[0, WALL_LO] - 0.002  # the Hertz absorber 2 mm into its left wall
    v = np.array([0.1, -0.05, 0.3, 0.2])
    stuck = np.array([0, 1])
    out = np.zeros((2, 4))
    _at_the_wall(x, v, scene.mass, 1.0 / scene.mass, scene.storey_k, scene.storey_c, scene.floor_c,
                 scene.kind, scene.host, scene.rows, scene.excitation, stuck, out)
    assert np.all(np.isfinite(out)) and not np.array_equal(out[0], out[1])
    signatures = _wall_accelerations.signatures
    assert len(signatures) == 1  # one compile for the floor count 2 and both sets of flags
    assert not any("Literal" in str(t) for t in signatures[0])
