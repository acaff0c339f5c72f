"""Paths in SIMD lanes (kernels/lanes.py): each realisation's metric vector is, bitwise, the one the
scalar loop gives on the same Philox streams, whatever its lane, batch or chunk; the scheme
registry says which scenes run there; and the update loop is vector code on the host."""

from __future__ import annotations

import dataclasses
import re

import llvmlite.binding as llvm
import numpy as np
import pytest
from numba import njit
from numba.core.caching import NullCache

from tests.helpers import changed, example_data, scene_from
from vines_stoch.jit import frontend
from vines_stoch.jit.flags import KERNEL, VECTOR_BITS
from vines_stoch.kernels import SLOTS, simulate, spec_of
from vines_stoch.kernels.chunk import lane_call, lane_scene, simulate_chunk
from vines_stoch.kernels.events import NONE, event_ahead, quiet_band
from vines_stoch.kernels.lanes import ALIGN, LANES, SPARE_ROWS, aligned_rows, lane_loop, lane_normals
from vines_stoch.outputs import STATUS, STATUS_DIVERGED, new_events, new_metrics
from vines_stoch.physics.absorbers import HERTZ as HERTZ_LAW
from vines_stoch.physics.absorbers import IMPACT as IMPACT_LAW
from vines_stoch.physics.absorbers import LAWS
from vines_stoch.schemes import in_lanes
from vines_stoch.signals import signal_names
from vines_stoch.streams import BRIDGE, FILTER, INCREMENTS, Streams
from vines_stoch.streams.rng import philox_stream

SEED = 20261127

SMOOTH = {
    "name": "lanes-smooth",
    "primary": {"mass": 1.0, "stiffness": 1.0, "damping": 0.02},
    "absorbers": [{"type": "cubic", "mass": 0.05, "stiffness": 1.0, "damping": 0.01}],
    "loads": [{"type": "harmonic", "amplitude": 0.1, "frequency": 1.0},
              {"type": "white-noise", "intensity": 0.05}],
    # 2,500 steps: across two of the divergence checks' phasor resets (every 1,024 steps)
    "simulation": {"duration": 2.5, "dt": 1e-3, "scheme": "euler-maruyama"},
    "limits": {"roof": {"metric": "x1_max", "value": 0.02}, "never": {"metric": "e1_max", "value": 1e9}},
}
FRAME = {
    "name": "lanes-frame",
    "primary": {"masses": [1.0, 1.0, 0.8], "stiffnesses": [40.0, 30.0, 20.0], "dampings": [0.2, 0.1, 0.1]},
    "absorbers": [{"type": "cubic", "mass": 0.05, "stiffness": 100.0, "damping": 0.02},
                  {"type": "linear", "floor": 2, "mass": 0.1, "stiffness": 2.0, "damping": 0.05},
                  {"type": "bistable", "floor": 1, "mass": 0.02, "stiffness": 50.0, "linear_stiffness": -0.2,
                   "damping": 0.01}],
    "loads": [{"type": "white-noise", "intensity": 0.3, "floor": 1},
              {"type": "white-noise", "intensity": 0.2},
              {"type": "harmonic", "amplitude": 0.5, "frequency": 3.0, "floor": 2},
              {"type": "blast", "amplitude": 2.0, "start": 0.3, "duration": 0.2, "decay": 1.0}],
    "simulation": {"duration": 2.2, "dt": 2e-3, "scheme": "euler-maruyama", "metrics_from": 0.77},
    "limits": {"drift": {"metric": "drift_max_2", "value": 0.01},
               "acc": {"metric": "acc_max_3", "value": 0.5}, "x1": {"metric": "x_max_1", "value": 0.005}},
}
GROUND = {
    "name": "lanes-ground",
    "primary": {"mass": 1.0, "stiffness": 4.0, "damping": 0.05},
    "absorbers": [{"type": "geometric", "mass": 0.05, "stiffness": 1.0, "free_length": 0.9, "length": 1.0,
                   "damping": 0.01}],
    "loads": [{"type": "base-harmonic", "amplitude": 0.3, "frequency": 2.0},
              {"type": "white-noise", "intensity": 0.1}],
    "simulation": {"duration": 2.0, "dt": 1e-3, "scheme": "euler-maruyama"},
}
#: Impacts under noise, and a double-sided Hertz absorber under noise alone (the structure of
#: ``test_hertz_noise_residual.py``'s scene: one lane loop for both): the lanes whose step holds
#: an event finish it in the scalar step.
IMPACT = {**SMOOTH, "name": "lanes-impact",
          "absorbers": [{"type": "cubic", "mass": 0.05, "stiffness": 1.0, "damping": 0.01},
                        {"type": "impact", "mass": 0.05, "clearance": 0.05, "restitution": 0.6}],
          "loads": [{"type": "harmonic", "amplitude": 0.3, "frequency": 1.0},
                    {"type": "white-noise", "intensity": 0.05}]}
HERTZ = {**SMOOTH, "name": "lanes-hertz",
         "absorbers": [{"type": "hertz", "geometry": "double-sided", "mass": 0.05, "stiffness": 0.05,
                        "damping": 0.0, "offset": 0.0, "gap": 0.05, "contact_left": {"k": 1e5},
                        "contact_right": {"k": 1e5}}],
         "loads": [{"type": "white-noise", "intensity": 0.3}]}
#: A plastic impact absorber (restitution 0): every impact sticks, and the scalar step takes each
#: step of a lane whose absorber is stuck.  Beside the impact scene's cubic absorber: the impact
#: scene's loop (one compile for both).
STICKY = {**IMPACT, "name": "lanes-sticky",
          "absorbers": [IMPACT["absorbers"][0], {**IMPACT["absorbers"][1], "restitution": 0.0}]}
#: A deterministic scene run by the kick-drift-kick scheme: the lanes draw nothing.
QUIET = {**SMOOTH, "loads": [{"type": "harmonic", "amplitude": 0.1, "frequency": 1.0}]}
#: Filtered noise beside white noise, from its stationary law, on a frame (a floor's filter),
#: and under a half-sine (loads with breaks: each step's start loads evaluated on its own
#: piece) with an impact absorber: each lane advances its own filters.
FILTERED = {**FRAME, "name": "lanes-filtered",
            "loads": [*FRAME["loads"], {"type": "filtered-noise", "intensity": 0.3, "frequency": 5.0,
                                        "damping": 0.2, "floor": 2, "start": "stationary"}]}
SHOCK = {**IMPACT, "name": "lanes-shock",
         "loads": [{"type": "half-sine", "amplitude": 0.5, "duration": 0.7, "start": 0.3},
                   {"type": "white-noise", "intensity": 0.05},
                   {"type": "filtered-noise", "intensity": 0.3, "frequency": 2.0, "damping": 0.3}]}


def philox_streams(r: int, point: int = 0, common: bool = True) -> Streams:
    """Realisation ``r``'s Philox streams (what a lane draws from)."""
    return Streams(*(philox_stream(SEED, p, r, point, common) for p in (INCREMENTS, BRIDGE, FILTER)))


def same(a: np.ndarray, b: np.ndarray) -> bool:
    """Bitwise equal, NaN where NaN."""
    return bool(np.all((a == b) | (np.isnan(a) & np.isnan(b))))


def contact_noise_parallel(duration: float = 2.0) -> dict:
    """The example scenario of steel-on-steel Hertz contact beside a plastic impact absorber
    under harmonic force and white noise (stuck about half the time), ``duration`` long."""
    return changed(example_data("contact_noise_parallel"), {"simulation.duration": duration})


def under_ground_motion(name: str, duration: float = 2.5) -> dict:
    """Example scenario ``name`` (Clough-Penzien ground motion with a Jennings envelope, no white
    noise: the filters' noise alone), ``duration`` long."""
    return changed(example_data(name), {"simulation.duration": duration})


#: ``make test-slow``'s scenes (``make test`` leaves them out): each compiles a lane loop and a
#: scalar loop of its own (35-45 s from a cold cache on 2 cores) for what the impact, contact and
#: ground scenes above check in ``make test`` too: shocks, and impacts and Hertz contact under
#: the ground motion's filters.
SLOW = pytest.mark.slow


@pytest.mark.parametrize("data", [
    pytest.param(SMOOTH, id="smooth"), pytest.param(FRAME, id="frame"), pytest.param(GROUND, id="ground"),
    pytest.param(QUIET, id="quiet"), pytest.param(IMPACT, id="impact"), pytest.param(HERTZ, id="hertz"),
    pytest.param(STICKY, id="sticky"), pytest.param(contact_noise_parallel(), id="contact-noise"),
    pytest.param(FILTERED, id="filtered"), pytest.param(SHOCK, id="shock", marks=SLOW),
    pytest.param(under_ground_motion("ground_motion"), id="ground-motion-impact", marks=SLOW),
    pytest.param(under_ground_motion("seed003_ss_ground_motion"), id="ground-motion-hertz", marks=SLOW)])
def test_a_lane_is_the_scalar_loop_on_its_philox_streams(data):
    scene = scene_from(data)
    assert lane_scene(scene)
    rows = simulate_chunk(scene, SEED, 0, 0, 5).raw
    for r in range(5):
        scalar = simulate(scene, philox_streams(r))
        assert same(rows[r], scalar), (r, np.flatnonzero(rows[r] != scalar))
    if data is not QUIET:  # the realisations differ (the noise is theirs)
        assert not np.array_equal(rows[0], rows[1])
    if data is STICKY or data is HERTZ:  # (each realisation has impacts, or contacts)
        assert rows[:, SLOTS.index("impacts")].min() > 0


def test_a_realisation_is_the_same_in_any_lane_batch_or_chunk():
    scene = scene_from({**SMOOTH, "simulation": {**SMOOTH["simulation"], "duration": 0.3}})
    n = LANES + 9  # two batches, the second a part one
    whole = simulate_chunk(scene, SEED, 0, 0, n).raw
    for start, stop in ((0, 1), (5, 12), (LANES - 2, LANES + 3), (n - 4, n)):
        assert same(simulate_chunk(scene, SEED, 0, start, stop).raw, whole[start:stop])
    assert same(whole[LANES + 4], simulate(scene, philox_streams(LANES + 4)))


def test_without_common_random_numbers_a_point_has_streams_of_its_own():
    scene = scene_from(SMOOTH)
    own = simulate_chunk(scene, SEED, 3, 2, 4, common=False).raw
    for j, r in enumerate((2, 3)):
        assert same(own[j], simulate(scene, philox_streams(r, point=3, common=False)))
    assert not np.array_equal(own, simulate_chunk(scene, SEED, 3, 2, 4, common=True).raw)


def test_a_path_that_diverges_ends_as_in_the_scalar_loop():
    """A step past the scheme's stability limit (set on the built scene): the paths blow up, each
    lane ends at the first divergence check that sees it, with the metrics the scalar loop
    writes there."""
    base = scene_from({**SMOOTH, "simulation": {**SMOOTH["simulation"], "duration": 3.0}})
    scene = dataclasses.replace(base, storey_k=base.storey_k * 4.05e6)  # omega dt = 2.01
    rows = simulate_chunk(scene, SEED, 0, 0, 3).raw
    for r in range(3):
        assert rows[r][STATUS] == STATUS_DIVERGED
        assert same(rows[r], simulate(scene, philox_streams(r)))


def test_a_batch_s_rows_start_on_cache_lines():
    """The batch's rows are 64-byte aligned (numba's own arrays: 32 bytes): each buffer starts on a
    cache line, and a row is a whole number of them."""
    for rows in (1, 3, 17):
        buffer = aligned_rows(rows)
        assert buffer.ctypes.data % ALIGN == 0 and ALIGN == 64
        assert buffer.shape == (rows * LANES,) and (LANES * 8) % ALIGN == 0


def test_the_registry_says_which_scenes_run_in_lanes():
    assert in_lanes("euler-maruyama")
    assert not in_lanes("sra")
    assert not in_lanes("rk4")
    assert lane_scene(scene_from(IMPACT)) and lane_scene(scene_from(HERTZ))
    assert lane_scene(scene_from(FILTERED)) and scene_from(FILTERED).filters["p0"].any()
    assert not lane_scene(scene_from(changed(SMOOTH, {"simulation.scheme": "sra"})))


@pytest.mark.parametrize("data", [SMOOTH, FILTERED, contact_noise_parallel()],
                         ids=["smooth", "filtered", "contact-noise"])
def test_lanes_keep_the_scalar_loop_s_history_rows(data):
    """History rows are recorded in the lanes, each lane's by the scalar loop's ``history_row``
    at the same step ends: a chunk that keeps them gives the metric rows of a chunk that keeps
    none, bitwise, and each realisation's rows are ``simulate``'s on its Philox streams, bitwise
    (every signal a floor and an absorber have, the absorbers' energy share among them)."""
    scene = scene_from(data)
    names = signal_names(scene.n_floors, scene.kind.shape[0])
    signals = tuple(name for name in names if not name.startswith("contact"))
    size = min(40, scene.n_steps // 50 + 1)  # (rows up to the path's end)
    plain = simulate_chunk(scene, SEED, 0, 0, 3).raw
    kept = simulate_chunk(scene, SEED, 0, 0, 3, history=(50, size), signals=signals)
    assert same(kept.raw, plain)
    for r in range(3):
        history = np.full((size, len(signals)), np.nan)
        simulate(scene, philox_streams(r), history=history, stride=50, signals=signals)
        assert same(kept.history[r], history), r
        assert not np.isnan(history).any()


def test_a_lane_that_diverges_keeps_no_history_rows_after_it():
    """A path that blows up ends at the divergence check that sees it: its history rows from there
    on stay NaN, in the lanes as in the scalar loop."""
    base = scene_from({**SMOOTH, "simulation": {**SMOOTH["simulation"], "duration": 3.0}})
    scene = dataclasses.replace(base, storey_k=base.storey_k * 4.05e6)  # omega dt = 2.01
    kept = simulate_chunk(scene, SEED, 0, 0, 2, history=(100, 31), signals=("x1", "e1"))
    for r in range(2):
        history = np.full((31, 2), np.nan)
        simulate(scene, philox_streams(r), history=history, stride=100, signals=("x1", "e1"))
        assert same(kept.history[r], history)
        assert np.isnan(history[-1]).all() and not np.isnan(history[0]).any()


#: What a run may record beyond the built-in metrics: declared metrics (the impact absorber's
#: force on its host, ``contact_2``, and the absorbers' energy share among them) and an event log.
RECORDED = {"output.metrics": ["x_1_rms", "e1_mean", "stroke_2_peak", "contact_2_max", "contact_2_peak",
                               "share_peak", "energy_share_mean", "va_1_min"],
            "output.events": 40, "simulation.metrics_from": 0.4}


@pytest.mark.parametrize("data", [changed(IMPACT, RECORDED), changed(HERTZ, {**RECORDED, "output.metrics": [
    "contact_1_peak", "stroke_1_rms"]}), changed(contact_noise_parallel(1.0), RECORDED)],
    ids=["impact", "hertz", "contact-noise (a plastic impact absorber)"])
def test_lanes_keep_the_scalar_loop_s_event_logs_and_declared_metrics(data):
    """Event logs, declared metrics and a history of the impacts' impulses (``contact_j``) are
    recorded in the lanes: each realisation's metric vector (its declared metrics in it), event
    log and history rows are ``simulate``'s on its Philox streams, bitwise; the events and the
    impacts' forces are there to record."""
    scene = scene_from(data)
    assert scene.reductions.shape[0] > 0 and scene.event_rows == 40
    signals = ("x1", "share", *(f"contact_{a + 1}" for a in range(scene.kind.shape[0])))
    size = scene.n_steps + 1  # (every step's end: the impulses of each step)
    kept = simulate_chunk(scene, SEED, 0, 0, 3, history=(1, size), signals=signals, event_rows=40)
    for r in range(3):
        history, events = np.full((size, len(signals)), np.nan), new_events(40)
        raw = simulate(scene, philox_streams(r), history=history, stride=1, signals=signals, events=events)
        assert same(kept.raw[r], raw), (r, np.flatnonzero(kept.raw[r] != raw))
        assert same(kept.events[r], events), r
        assert same(kept.history[r], history), r
    assert not np.isnan(kept.events[:, 0]).any()  # (each realisation logged an event)
    assert np.abs(kept.history[:, :, 2:]).max() > 0  # (and an absorber pushed its host)


def _packed(asm: str, width: str, kind: str = "pd") -> int:
    """Packed arithmetic on ``width`` registers (``ymm``, ``zmm``; a pattern) in ``asm``, of double
    precision (``kind``: ``pd``) or single (``ps``)."""
    ops = rf"fn?m(?:add|sub)\d*{kind}|mul{kind}|add{kind}|sub{kind}|sqrt{kind}"
    return len(re.findall(rf"\bv(?:{ops})\b[^\n]*%{width}", asm))


@pytest.mark.parametrize("data", [SMOOTH, IMPACT, HERTZ], ids=["smooth", "impact", "hertz"])
def test_the_lane_loops_are_vector_code_on_this_host(data):
    """The update loop compiles to packed arithmetic on the registers of the width it asks for
    (``flags.VECTOR_BITS``, 512 unless set) as far as the host has them: ``zmm`` on an AVX-512
    host, ``ymm`` on an AVX2 host, with and without events; the normals to packed ``float32``
    arithmetic (on ``ymm`` registers where their 64-bit Philox words fill ``zmm``); skipped on a
    host without AVX2.  The lane loop holds the normals' loop too:
    beyond the normals' own packed arithmetic, a scalar update loop left 5 instructions (an
    impact scene's, where one float sum kept it scalar), a vector one 110 to 180 (AVX2 host)."""
    if not llvm.get_host_cpu_features().get("avx2"):
        pytest.skip("no AVX2 on this host")
    run = compiled_here(scene_from(data))
    normals = njit(**{**KERNEL, "cache": False})(lane_normals.py_func)
    normals(np.zeros(8), np.zeros((SPARE_ROWS, 8)), 8, 0, np.uint64(1), np.arange(8, dtype=np.uint64), 0)
    update = run.inspect_asm(run.signatures[0])
    drawn = normals.inspect_asm(normals.signatures[0])
    host = 512 if llvm.get_host_cpu_features().get("avx512f") else 256
    wide = {128: "xmm", 256: "ymm", 512: "zmm"}[min(host, VECTOR_BITS)]
    # (the normals' float32 arithmetic: vectors as many lanes wide as their Philox words', 64-bit)
    assert _packed(drawn, "[yz]mm", "ps") >= 10 and re.search(r"vsqrtps[^\n]*%[yz]mm", drawn), \
        "the lanes' normals are not vectorised"
    assert _packed(update, wide) - _packed(drawn, wide) >= 40, "the lane update loop is not vectorised"


def compiled_here(scene):
    """``scene``'s lane loop compiled by this process, whose machine code numba can show (it
    shows none of a loop it loaded from its cache): the package's own loop where this process
    compiled it (in this test or an earlier one: one compile for both), else the loop compiled
    again without the cache."""
    simulate_chunk(scene, SEED, 0, 0, 2)
    run = lane_loop(spec_of(scene, lanes=True))
    if sum(run.stats.cache_misses.values()) > 0:
        return run
    run = lane_loop.__wrapped__(spec_of(scene, lanes=True))  # (not the memoised one)
    run._cache = NullCache()
    with frontend.compiling():  # (the package's faster front end, as its own compiles)
        run(*lane_call(scene, SEED, 0, 0, True, new_metrics_rows(scene, 2)))
    return run


#: Runs ``simulate_chunk`` of the impact scene (its first argument: the scene's data as JSON) on
#: 200 realisations and saves the metric rows to the file named by its second.
_WIDTH_SCRIPT = """
import json, sys
import numpy as np
from tests.helpers import scene_from
from vines_stoch.kernels.chunk import simulate_chunk
np.save(sys.argv[2], simulate_chunk(scene_from(json.loads(sys.argv[1])), 20261127, 0, 0, 200).raw)
"""


@pytest.mark.slow  # (a lane loop compiled afresh in a process of its own: about 60 s on 2 cores)
def test_the_vector_width_changes_no_number(tmp_path):
    """The lane loops asked for 256-bit vectors (``VINES_STOCH_VECTOR_BITS=256``, in a process of
    its own, its cache in a folder of its own) give the impact scene's metric rows bitwise as the
    default width does (on an AVX-512 host: ymm against zmm code); a width outside 128, 256 and
    512 stops with an error naming the variable, the value and the widths allowed."""
    import json
    import os
    import subprocess
    import sys

    from tests.helpers import ROOT
    from vines_stoch.jit import flags

    other = 256 if VECTOR_BITS != 256 else 512
    path = os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))
    env = {**os.environ, "VINES_STOCH_VECTOR_BITS": str(other), "NUMBA_CACHE_DIR": str(tmp_path / "cache"),
           "PYTHONPATH": path}
    saved = tmp_path / "rows.npy"
    done = subprocess.run([sys.executable, "-c", _WIDTH_SCRIPT, json.dumps(IMPACT), str(saved)], env=env,
                          cwd=ROOT, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr[-3000:]
    here = simulate_chunk(scene_from(IMPACT), SEED, 0, 0, 200).raw
    assert lane_scene(scene_from(IMPACT)) and here[:, SLOTS.index("impacts")].sum() > 0  # (lanes, impacts)
    np.testing.assert_array_equal(np.load(saved), here)

    os.environ["VINES_STOCH_VECTOR_BITS"] = "300"
    try:
        with pytest.raises(ValueError, match=r"VINES_STOCH_VECTOR_BITS='300'.*128, 256, 512"):
            flags.vector_bits()
    finally:
        del os.environ["VINES_STOCH_VECTOR_BITS"]


def new_metrics_rows(scene, n: int) -> np.ndarray:
    """``n`` metric vectors at their start."""
    return np.tile(new_metrics(scene.n_floors, scene.limits.shape[0], scene.reductions.shape[0]), (n, 1))


@pytest.mark.parametrize("law", sorted(LAWS))
def test_the_lanes_event_band_is_the_event_test_of_the_scalar_step(law):
    """``events.quiet_band`` (the lanes' test, without a branch) says no event exactly where
    ``events.event_ahead`` (the scalar step's) finds none, for an absorber neither stuck nor
    touching: on random displacements and on the band's ends."""
    code, clearance, lo, hi = LAWS[law], 0.05, -0.03, 0.07
    band = quiet_band(code, clearance, lo, hi)
    u = np.concatenate([np.random.default_rng(3).uniform(-0.2, 0.2, 2000), [-clearance, clearance, lo, hi]])
    u = np.concatenate([u, np.nextafter(u[-4:], np.inf), np.nextafter(u[-4:], -np.inf)])
    for value in u:
        event = event_ahead(code, 0, 0, clearance, lo, hi, value, True, True, True)[0]
        assert (event == NONE) == (band[0] <= value <= band[1]), (law, value)
    if code not in (IMPACT_LAW, HERTZ_LAW):
        assert band == (-np.inf, np.inf)
