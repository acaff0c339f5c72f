"""The general loop of each scheme (``paths.spec_of(general=True)``): every size (bodies, floors,
load rows, filter states) and every kind a scene holds (white noise, impact and Hertz absorbers,
impacts between absorbers, filtered loads, ground acceleration, shaped springs) read at run
time.  It gives, bitwise, the numbers of the loop specialised to the scene (and, on the Philox
streams, of the SIMD lanes); and scenes never run before, of any structure, run it without
compiling anything."""

from __future__ import annotations

import math
import os

import numpy as np
import pandas as pd
import pytest
from numba.core.caching import NullCache

import vines_stoch
from tests.helpers import example_scene, scene_from, study_from
from tests.unit.kernels.test_lanes import FILTERED, SEED, SMOOTH, philox_streams, same
from tests.unit.kernels.test_passes import (
    BISTABLE,
    BLAST,
    CLOUGH_PENZIEN,
    CUBIC,
    GAP,
    GEOMETRIC,
    GROUND,
    HARMONIC,
    NOISE,
    RECORDED,
    frame,
)
from vines_stoch.ensemble import plan, planning
from vines_stoch.ensemble.ahead import GENERAL_PIECES, GENERAL_SET, compile_general, general_scene
from vines_stoch.environment import problems
from vines_stoch.kernels import chunk as chunk_module
from vines_stoch.kernels import (
    chunk_runner,
    in_pass_loop,
    kernel_for,
    pass_loop,
    simulate,
    simulate_chunk,
    start_path,
)
from vines_stoch.kernels.chunk import PASS_LANES, chunk_loop, lane_runner, simulate_lanes
from vines_stoch.kernels.driver import step_loop
from vines_stoch.kernels.lanes import lane_loop
from vines_stoch.kernels.paths import GENERAL_WORK, general_run, spec_of
from vines_stoch.kernels.protocol import KINDS, RUN_TIME

IMPACT = {"type": "impact", "mass": 0.05, "clearance": 0.01, "restitution": 0.6}
STEEL = {"young": [2.1e11, 2.1e11], "poisson": [0.3, 0.3], "radius": 0.01}
HERTZ = {"type": "hertz", "geometry": "double-sided", "mass": 0.05, "stiffness": 2.0, "damping": 0.05,
         "offset": 0.005, "gap": 0.01, "contact_left": STEEL, "contact_right": STEEL}

#: Scenes of every scheme and kind: the kick-drift-kick step with impacts, Hertz contact and
#: plastic impacts under noise (on the Brownian trees), filtered loads from their stationary law,
#: stochastic ground motion, shaped springs and a harmonic ground acceleration, a nine-storey
#: frame, an impact absorber in another's cavity; the RK4 step with impacts and with Hertz
#: contact; the SRA3 step.
CASES = {
    "kdk, impacts under noise": lambda: example_scene("parallel_nes_noise", {"simulation.duration": 4.0}),
    "kdk, Hertz contact and plastic impacts under noise": lambda: example_scene(
        "contact_noise_parallel", {"simulation.duration": 1.5}),
    "kdk, filtered noise from its stationary law": lambda: scene_from(FILTERED),
    "kdk, Clough-Penzien ground motion, recorded": lambda: scene_from(
        frame(3, [CUBIC], [CLOUGH_PENZIEN, {**NOISE, "floor": 1}], **RECORDED)),
    "kdk, shaped springs under a ground acceleration": lambda: scene_from(
        frame(2, [GEOMETRIC, {**GAP, "floor": 1}], [GROUND, NOISE])),
    "kdk, an impact absorber in another's cavity": lambda: example_scene(
        "seed001_frame_vidm", {"simulation.duration": 3.0}),
    "rk4, impacts": lambda: example_scene("parallel_nes_impulse", {"simulation.duration": 10.0}, "rk4"),
    "rk4, Hertz contact": lambda: example_scene("seed003_ds20", {"simulation.duration": 10.0,
                                                                  "simulation.metrics_from": 2.5}, "rk4"),
    "sra3": lambda: scene_from(frame(4, [BISTABLE], [HARMONIC, NOISE], **{"simulation.scheme": "sra"})),
}


def test_the_general_spec_reads_every_size_and_kind_at_run_time():
    spec = spec_of(scene_from(frame(5, [CUBIC], [NOISE])), general=True)
    assert spec.n_bodies == spec.n_floors == spec.n_rows == spec.n_states == RUN_TIME
    assert all(getattr(spec, name) == RUN_TIME for name in KINDS)
    assert spec_of(scene_from(frame(5, [CUBIC], [NOISE])), general=True) == spec_of(
        scene_from(frame(2, [HERTZ, {**IMPACT, "floor": 1}], [CLOUGH_PENZIEN])), general=True)


#: The cases ``make test`` leaves to ``make test-slow``: each compiles two or three loops
#: specialised to its scene that no other test of ``make test`` needs (20-70 s from a cold cache
#: on 2 cores).  The kick-drift-kick step with Hertz contact and plastic impacts under noise, the
#: RK4 step with Hertz contact and the SRA3 step stay in ``make test``: the first two run loops
#: that its chunk, lanes and records tests compile too.
SLOW_CASES = {"kdk, impacts under noise",
              "kdk, filtered noise from its stationary law",
              "kdk, Clough-Penzien ground motion, recorded",
              "kdk, shaped springs under a ground acceleration",
              "kdk, an impact absorber in another's cavity", "rk4, impacts"}


@pytest.mark.parametrize("case", [pytest.param(case, marks=pytest.mark.slow) if case in SLOW_CASES else case
                                  for case in CASES])
def test_the_general_loop_gives_the_specialised_loop_s_numbers_bitwise(case):
    """The scalar loop on the PCG64 streams, and where the scheme runs in lanes the lanes' Philox
    streams: the metric vectors, history rows and event logs of the general loop are those of
    the loops specialised to the scene, bit for bit."""
    scene = CASES[case]()
    records = {"history": (max(scene.n_steps // 6, 1), 6), "signals": ("x1", "e1", "v_1"),
               "event_rows": 16}
    for executor in ("scalar", "lanes"):
        general = simulate_chunk(scene, SEED, 0, 0, 3, executor=executor, general=True, **records)
        special = simulate_chunk(scene, SEED, 0, 0, 3, executor=executor, **records)
        for name in ("raw", "history", "events", "samples"):
            assert same(getattr(general, name), getattr(special, name)), (executor, name)
    assert np.isfinite(general.raw[:, 0]).all()


def _structures():
    """Scenes never run before: 1, 2, 3, 5 and 9 storeys; no absorber, a cubic, a bistable, a
    geometric, a gap, an impact and a Hertz absorber, two at once; harmonic, blast, white noise,
    ground motion; declared metrics and limits."""
    return [
        frame(1, [], [HARMONIC]),
        frame(1, [{**IMPACT, "clearance": 0.02}], [NOISE]),
        frame(2, [BISTABLE, {**GEOMETRIC, "floor": 1}], [GROUND, BLAST]),
        frame(5, [{**HERTZ, "floor": 5}], [{**NOISE, "floor": 3}, HARMONIC], **RECORDED),
        frame(9, [CUBIC, {**IMPACT, "floor": 8}], [CLOUGH_PENZIEN]),
        frame(9, [], [NOISE], **{"simulation.scheme": "sra"}),
        frame(5, [{**IMPACT, "floor": 3}, {**HERTZ, "floor": 5}], [BLAST], **{"simulation.scheme": "rk4"}),
        frame(3, [CUBIC, {**GAP, "floor": 2}], [NOISE, CLOUGH_PENZIEN], **RECORDED),
    ]


def test_compile_general_hands_its_processes_every_general_loop_once():
    """``compile_general``'s pieces are each scheme's general loops under each load of
    ``GENERAL_SET``, and the pass loop, each once."""
    assert sorted((scheme, load) for scheme, load, what in GENERAL_PIECES if what == "loops") == sorted(
        GENERAL_SET)
    assert [what for _, _, what in GENERAL_PIECES].count("pass") == 1


def test_new_structures_run_the_general_loop_and_compile_nothing():
    """After ``compile_general`` (``vines-stoch compile --general``: each scheme's general loop
    once, and the pass loop), scenes of other storeys, absorbers, loads and outputs run them as
    paths and as chunks of either executor: no loop is made, none compiles a new signature
    (numba's dispatcher statistics), and none is loaded from the cache."""
    compile_general(show=False, workers=1)  # (in this process: its dispatchers are counted)
    first = [general_scene(scheme, load) for scheme, load in GENERAL_SET]
    loops = {id(kernel_for(s, general=True)): kernel_for(s, general=True) for s in first}
    chunks = [chunk_loop(k) for k in loops.values()] + [pass_loop]
    made = _made()
    compiled = _compiled((*loops.values(), *chunks))
    for data in _structures():
        scene = scene_from(data)
        simulate(scene, np.random.default_rng(2), history=np.zeros((4, 2)), stride=10)
        for executor in ("scalar", "lanes"):
            simulate_chunk(scene, SEED, 0, 0, 2, executor=executor, general=True, history=(10, 4),
                           signals=("x1", "e1"), event_rows=4)
        if in_pass_loop(scene, general=True):  # (a chunk the pass loop takes in a short run)
            simulate_chunk(scene, SEED, 0, 0, PASS_LANES, general=True, history=(10, 4), signals=("x1", "e1"),
                           event_rows=4)
    assert len(loops) == 3
    assert _made() == made and _compiled((*loops.values(), *chunks)) == compiled


def test_a_pass_loop_structure_runs_chunks_of_16_in_the_pass_loop_and_smaller_ones_in_the_general_loop(
        monkeypatch):
    """A smooth kick-drift-kick structure of three bodies or more runs a chunk of ``PASS_LANES``
    realisations or more in the pass loop however short or long the run (itself one loop for
    every such structure: ``kernels.in_pass_loop``), a smaller chunk (a path, ``solve``, a
    realisation with parameters of its own) in the general scalar loop on the same Philox streams
    however long the run (``kernels.lane_chunk``, ``kernels.scalar_general``), the scalar
    executor's in the scalar loop (the general one in a short run); the pass loop's rows are the
    general loop's paths on the same Philox streams, bitwise, so the choice moves no number."""
    monkeypatch.delenv("VINES_STOCH_GENERAL_WORK", raising=False)
    scene = scene_from(frame(2, [CUBIC], [NOISE]))
    study = study_from(frame(2, [CUBIC], [NOISE]), {"ensemble.realizations": 40})
    assert scene.mass.shape[0] == 3 and general_run(40 * scene.n_steps) and in_pass_loop(scene)
    assert plan(study).general and plan(study).batch == 40
    general = chunk_loop(kernel_for(scene, general=True))
    for short in (True, False):
        assert chunk_runner(scene, "lanes", general=short, batch=PASS_LANES) is pass_loop
        assert chunk_runner(scene, "lanes", general=short, batch=PASS_LANES - 1) is general
    assert chunk_runner(scene, "scalar", general=True) is general
    assert chunk_runner(scene, "scalar", general=False) is chunk_loop(kernel_for(scene))
    assert not in_pass_loop(scene, "scalar") and not in_pass_loop(scene, specialised=True)
    assert not in_pass_loop(scene_from(frame(1, [CUBIC], [NOISE])))  # (two bodies: a long run's own loop)
    lanes = []  # (the chunks that ran in SIMD lanes)
    monkeypatch.setattr(chunk_module, "simulate_lanes", lambda *args, **kwargs: lanes.append(
        simulate_lanes(*args, **kwargs)))
    rows = simulate_chunk(scene, SEED, 0, 0, PASS_LANES, general=True).raw
    long_rows = simulate_chunk(scene, SEED, 0, 0, PASS_LANES).raw
    few = simulate_chunk(scene, SEED, 0, 0, 2, general=True).raw
    long_few = simulate_chunk(scene, SEED, 0, 0, 2).raw
    assert len(lanes) == 2  # (the chunks of PASS_LANES alone)
    assert same(long_rows, rows)
    for r in range(2):  # (a path: the general loop, on the realisation's Philox streams)
        assert same(rows[r], simulate(scene, philox_streams(r))) and same(few[r], rows[r])
        assert same(long_few[r], rows[r])


@pytest.mark.parametrize("bodies", [1, 2])
def test_a_short_run_of_one_or_two_bodies_runs_its_lanes_in_the_pass_loop(monkeypatch, bodies):
    """In a short run a smooth structure of one or two bodies runs its chunks of ``PASS_LANES``
    or more in the pass loop (compiled once for every structure), not the general scalar loop; a
    long run in the lane loop specialised to it; its rows are the general scalar loop's on the
    same Philox streams, bitwise (and so the specialised lanes': ``test_lanes.py``)."""
    data = frame(1, [CUBIC] if bodies == 2 else [], [NOISE, HARMONIC])
    scene = scene_from(data)
    assert scene.mass.shape[0] == bodies
    assert in_pass_loop(scene, general=True) and not in_pass_loop(scene)
    assert not in_pass_loop(scene, general=True, realisations=PASS_LANES - 1)
    assert chunk_runner(scene, "lanes", general=True) is pass_loop
    assert chunk_runner(scene, "lanes", general=False) is lane_loop(spec_of(scene, lanes=True))
    assert chunk_runner(scene, "lanes", general=True, batch=PASS_LANES - 1) is chunk_loop(
        kernel_for(scene, general=True))
    runners = []
    monkeypatch.setattr(chunk_module, "lane_runner", lambda *args, **kwargs: runners.append(
        lane_runner(*args, **kwargs)) or runners[-1])
    rows = simulate_chunk(scene, SEED, 0, 0, PASS_LANES, general=True).raw
    assert runners == [pass_loop]
    for r in (0, PASS_LANES - 1):  # (a path in the general loop, on the realisation's Philox streams)
        assert same(rows[r], simulate(scene, philox_streams(r)))


def _made() -> tuple[int, int, int]:
    """The step loops, lane loops and chunk loops this process has made."""
    return step_loop.cache_info().currsize, lane_loop.cache_info().currsize, chunk_loop.cache_info().currsize


def _compiled(dispatchers) -> list[tuple[int, int, int]]:
    """Each dispatcher's signatures, compilations and loads from the cache (numba's statistics)."""
    return [(len(d.overloads), sum(d.stats.cache_misses.values()), sum(d.stats.cache_hits.values()))
            for d in dispatchers]


def test_short_runs_take_the_general_loop_and_long_runs_a_specialised_one(monkeypatch):
    monkeypatch.delenv("VINES_STOCH_GENERAL_WORK", raising=False)  # (the suite's: every run general)
    scene = scene_from(frame(2, [CUBIC], [NOISE]))
    assert general_run(scene.n_steps) and general_run(GENERAL_WORK - 1) and not general_run(GENERAL_WORK)
    monkeypatch.setenv("VINES_STOCH_GENERAL_WORK", str(GENERAL_WORK))  # (the work alone: the next test)
    assert start_path(scene, np.random.default_rng(0)).kernel is kernel_for(scene, general=True)
    monkeypatch.setenv("VINES_STOCH_GENERAL_WORK", "1e3")
    assert general_run(999) and not general_run(1000)
    monkeypatch.setenv("VINES_STOCH_GENERAL_WORK", "0")
    assert not general_run(0) and not general_run(1)
    monkeypatch.setenv("VINES_STOCH_GENERAL_WORK", "inf")
    assert general_run(10**18)


def test_a_run_the_pass_loop_takes_when_short_counts_its_work_pass_work_times_cheaper(monkeypatch):
    """Toward ``GENERAL_WORK`` the path-steps of a smooth structure of one or two bodies, whose
    chunks a short run gives to the pass loop, count ``PASS_WORK`` times cheaper (the pass
    loop's speed over the general scalar loop's); an impact absorber's (the general scalar loop
    when short), the SRA3 scheme's (no lanes), a frame's of three bodies (the pass loop however
    long) and those of a study with uncertain parameters (each realisation alone) at their full
    count."""
    from vines_stoch.ensemble.planning import PASS_WORK

    monkeypatch.delenv("VINES_STOCH_GENERAL_WORK", raising=False)
    smooth = frame(1, [CUBIC], [NOISE])
    steps = scene_from(smooth).n_steps

    def general(data, work, **changes):
        return plan(study_from(data, {"ensemble.realizations": math.ceil(work / steps), **changes})).general

    for work in (2 * GENERAL_WORK, 0.9 * PASS_WORK * GENERAL_WORK):
        assert general(smooth, work)
    assert not general(smooth, 1.1 * PASS_WORK * GENERAL_WORK)
    assert not general(smooth, 2 * GENERAL_WORK, **{"simulation.scheme": "sra"})
    assert not general(frame(1, [CUBIC, {**IMPACT, "floor": 1}], [NOISE]), 2 * GENERAL_WORK)
    assert not general(frame(2, [CUBIC], [NOISE]), 2 * GENERAL_WORK)
    lognormal = {"distribution": "lognormal", "median": 100.0, "cov": 0.1}
    uncertain = {**smooth, "uncertain": {"absorbers.0.stiffness": lognormal}}
    assert not general(uncertain, 2 * GENERAL_WORK)
    assert general(smooth, 0.9 * GENERAL_WORK, **{"simulation.scheme": "sra"})


def test_a_short_run_takes_the_specialised_loop_where_it_is_compiled_with_the_same_numbers(monkeypatch):
    """A run shorter than ``GENERAL_WORK`` with ``VINES_STOCH_GENERAL_WORK`` unset takes the loop
    specialised to its structure where that is compiled already (here in this process; on disk,
    loaded: ``planning.specialised_loops``), ``solve`` too; the rows and the path are those of the
    loops compiled once for every structure, bitwise, which a run takes with the variable set (its
    work alone decides): the pass loop for the run's chunk, the general scalar loop for the path."""
    scene, study = scene_from(SMOOTH), study_from(SMOOTH, {"ensemble.realizations": 20})
    simulate_chunk(scene, SEED, 0, 0, 2)  # (the lane loop specialised to the structure, compiled or loaded)
    assert not in_pass_loop(scene) and lane_runner(scene) is lane_loop(spec_of(scene, lanes=True))
    ran = []  # (the realisations each call ran in SIMD lanes: none in a look, some in a run)
    monkeypatch.setattr(chunk_module, "simulate_lanes", lambda *args, **kwargs: ran.append(
        args[5].shape[0]) or simulate_lanes(*args, **kwargs))
    monkeypatch.delenv("VINES_STOCH_GENERAL_WORK")
    assert plan(study).general
    fast, _ = vines_stoch.run(study, workers=1)
    one = vines_stoch.solve(study, realization=3)
    assert sum(ran) == 20 + 1, ran  # (the run's realisations and the path of ``solve``, in lanes)
    monkeypatch.setenv("VINES_STOCH_GENERAL_WORK", str(GENERAL_WORK))
    ran.clear()
    runners = []
    monkeypatch.setattr(chunk_module, "lane_runner", lambda *args, **kwargs: runners.append(
        lane_runner(*args, **kwargs)) or runners[-1])
    general, _ = vines_stoch.run(study, workers=1)
    one_general = vines_stoch.solve(study, realization=3)
    # (the run's chunk in the pass loop, the path of ``solve`` in the general scalar loop, on the
    # same Philox streams)
    assert sum(ran) == 20 and set(runners) == {pass_loop}, (ran, runners)
    pd.testing.assert_frame_equal(fast, general, check_exact=True)
    pd.testing.assert_series_equal(one.metrics, one_general.metrics, check_exact=True)
    for name in one.ys:
        np.testing.assert_array_equal(one.ys[name], one_general.ys[name])


def test_a_short_path_takes_the_specialised_loop_where_it_is_compiled_with_the_same_numbers(monkeypatch):
    """``simulate`` and ``start_path`` likewise (``kernels.keeps_general``): a short path takes the
    step loop specialised to its structure where it is compiled (or on disk), the general one's
    numbers bitwise."""
    scene = scene_from(frame(1, [], [HARMONIC], **{"simulation.scheme": "rk4"}))
    final, general_final = np.zeros((2, 1)), np.zeros((2, 1))
    monkeypatch.setenv("VINES_STOCH_GENERAL_WORK", "0")
    simulate(scene)  # (the specialised loop: compiled or loaded)
    monkeypatch.delenv("VINES_STOCH_GENERAL_WORK")
    assert general_run(scene.n_steps) and start_path(scene).kernel is kernel_for(scene)
    fast = simulate(scene, final=final)
    monkeypatch.setenv("VINES_STOCH_GENERAL_WORK", str(GENERAL_WORK))
    assert start_path(scene).kernel is kernel_for(scene, general=True)
    assert same(fast, simulate(scene, final=general_final)) and same(final, general_final)


def test_a_short_run_looks_for_a_specialised_loop_once_and_compiles_nothing(monkeypatch):
    """Where the specialised loop is neither compiled nor on disk (a fresh one without a cache,
    here), a short run takes the loops compiled once (the pass loop, the general loop): looking
    for it compiled nothing (numba's statistics: one miss, no signature), and the process does
    not look for it again."""
    scene, study = scene_from(SMOOTH), study_from(SMOOTH, {"ensemble.realizations": 20})
    fresh = lane_loop.__wrapped__(spec_of(scene, lanes=True))  # (not the memoised one)
    fresh._cache = NullCache()
    monkeypatch.setattr(chunk_module, "lane_runner", lambda scene, specialised=False, general=False: (
        lane_runner(scene, specialised, general) if general else fresh))  # (a short run's: the pass loop)
    monkeypatch.delenv("VINES_STOCH_GENERAL_WORK")
    assert not planning.specialised_loops([scene], SEED, True, executor="lanes", batch=20, show=False)
    assert len(fresh.overloads) == 0 and sum(fresh.stats.cache_misses.values()) == 1
    rows, _ = vines_stoch.run(study, workers=1)
    assert len(fresh.overloads) == 0 and sum(fresh.stats.cache_misses.values()) == 1
    monkeypatch.setenv("VINES_STOCH_GENERAL_WORK", str(GENERAL_WORK))
    pd.testing.assert_frame_equal(rows, vines_stoch.run(study, workers=1)[0], check_exact=True)


@pytest.mark.parametrize("value", ["many", "-1", "nan"])
def test_a_general_work_it_cannot_take_is_named_with_what_it_takes(monkeypatch, value):
    monkeypatch.setenv("VINES_STOCH_GENERAL_WORK", value)
    with pytest.raises(ValueError, match=f"VINES_STOCH_GENERAL_WORK='{value}'.*a number >= 0"):
        general_run(1)
    assert any("VINES_STOCH_GENERAL_WORK" in line for line in problems())


def test_the_bench_times_the_specialised_loops_and_starts_fresh_processes_as_a_user_s(monkeypatch):
    """``make bench``'s throughput rows run the loops specialised to their structure whatever their
    work (``bench.main``), its general-loop row the general loop, and the processes of its start-up
    section the default choice; the variable is as it was after each block."""
    from vines_stoch.validation import bench

    monkeypatch.delenv("VINES_STOCH_GENERAL_WORK", raising=False)
    with bench._general_work("0"):
        assert not general_run(1) and "VINES_STOCH_GENERAL_WORK" not in bench._fresh_env(A="1")
        with bench._general_work("inf"):
            assert general_run(10**18)
        assert not general_run(1)
    assert "VINES_STOCH_GENERAL_WORK" not in os.environ and general_run(1)
