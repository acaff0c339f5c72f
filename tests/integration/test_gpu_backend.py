"""The cuda backend (gpu.py, kernels/launch.py) on numba-cuda's simulator: the launcher runs each
realisation's step loop with its Philox streams, so a GPU realisation is the CPU loop's run on
the same streams; deterministic scenes give the CPU's metrics; batches and launch sizes change
nothing; the ensembles of both backends sample the same law. With ``NUMBA_ENABLE_CUDASIM=0`` on a
GPU the same tests run the compiled kernels, a thread's output then the CPU loop's up to rounding
(``assert_cpu_loop``)."""

from __future__ import annotations

import dataclasses
import math
import os
import subprocess
import sys
import threading

import numpy as np
import pandas as pd
import pytest

from tests.helpers import ROOT, changed, cli, example_data, scene_from, study_from
from tests.integration.test_ensemble import DATA
from vines_stoch import gpu, kernels, run
from vines_stoch.kernels import SLOTS, general_run, kernel_for, sample_buffer, simulate
from vines_stoch.outputs import new_events
from vines_stoch.store import read_metadata
from vines_stoch.streams import BRIDGE, FILTER, INCREMENTS, Streams, streams
from vines_stoch.streams.rng import keyed_stream, philox_stream
from vines_stoch.validation import bench_gpu
from vines_stoch.validation.scenes import scene_data

pytestmark = pytest.mark.skipif(gpu.unavailable() is not None, reason=f"cuda backend: {gpu.unavailable()}")

_S = {name: i for i, name in enumerate(SLOTS)}
#: On a GPU a thread's output is the CPU loop's up to rounding: numba-cuda takes exp, log, sin and
#: cos from libdevice (within 2 ulp of the CPU's libm) and NVVM fuses multiply-adds, so the two
#: round differently at every step. How far rounding alone moves a path is measured on the CPU
#: loop itself: its spread when the storey stiffness, the masses or the storey damping is scaled
#: by 1 +- k 2**-52 (k in ``ULPS``: 18 runs). One such change is not enough: on an H200 a path of
#: the impact oscillator (``test_paths_run_in_stretches_on_the_gpu_are_the_cpu_loop``, r = 1) had
#: one impact more on the GPU, and on the CPU the same path gains 2 impacts when the stiffness
#: moves by -1 ulp, 66 when the mass does, and none at +-4 ulp of stiffness, the one change the
#: bound took before. ``SPREAD_MARGIN`` allows for rounding that differs at every step rather
#: than once.
SPREAD_MARGIN = 10.0
#: The sizes, in units of 2**-52, of the relative changes whose effect bounds the GPU's gap.
ULPS = (1, 2, 4)
#: The scene arrays those changes scale, one at a time.
ROUNDED = ("storey_k", "mass", "storey_c")


def philox_streams(seed: int, r: int, point: int = 0, common: bool = True) -> Streams:
    """The streams GPU realisation ``r`` draws from, for the CPU loop."""
    return Streams(*(philox_stream(seed, p, r, point, common) for p in (INCREMENTS, BRIDGE, FILTER)))


def rounding_spread(scene, run, desired: np.ndarray) -> np.ndarray:
    """The largest move of each output of ``run(scene)`` (``desired``) under the changes of
    ``ROUNDED`` by ``ULPS`` (NaN moves ignored)."""
    spread = np.zeros(np.shape(desired))
    for name in ROUNDED:
        for k in ULPS:
            for sign in (1.0, -1.0):
                factor = 1.0 + sign * k * 2.0**-52
                moved = run(dataclasses.replace(scene, **{name: getattr(scene, name) * factor}))
                spread = np.fmax(spread, np.abs(moved - desired))
    return spread


def within_rounding(actual: np.ndarray, scene, run) -> float:
    """The largest gap between ``actual`` and ``run(scene)`` where the latter is finite, as a
    fraction of its bound: ``SPREAD_MARGIN`` times ``rounding_spread`` plus 16 ulp of the value
    (a gap where the bound is 0: infinite); NaN must fall where the CPU's does."""
    desired = run(scene)
    finite = np.isfinite(desired)
    np.testing.assert_array_equal(np.isfinite(actual), finite)
    gap = np.abs(actual - desired)[finite]
    spread = rounding_spread(scene, run, desired)[finite]
    bound = SPREAD_MARGIN * spread + 16.0 * np.finfo(float).eps * np.abs(desired[finite])
    fraction = np.divide(gap, bound, out=np.where(gap > 0, np.inf, 0.0), where=bound > 0)
    worst = int(np.argmax(fraction)) if fraction.size else 0
    used = float(np.max(fraction, initial=0.0))
    where = f" at output {np.flatnonzero(finite)[worst]}" if fraction.size else ""
    print(f"GPU - CPU: {used:.3g} of the bound{where} (largest gap {np.max(gap, initial=0.0):.3g})")
    return used


def assert_cpu_loop(actual: np.ndarray, scene, run) -> None:
    """``actual`` (a GPU thread's metric row or event log) is ``run(scene)``, the CPU loop on the
    thread's Philox streams: bitwise on the simulator (the same compiled loop); on a GPU, where
    finite, within the CPU loop's own spread under rounding (``within_rounding``)."""
    if gpu.simulating():
        np.testing.assert_array_equal(actual, run(scene))
        return
    assert within_rounding(actual, scene, run) <= 1.0


def test_the_rounding_bound_takes_the_cpu_loops_own_moves_and_refuses_an_error():
    """``within_rounding`` (the GPU check of ``assert_cpu_loop``) on the CPU alone, for a smooth
    noisy path: the CPU loop with the stiffness moved by 3 ulp (a change it does not make itself)
    is within the bound; the same outputs with one of them off by a millionth are not."""
    scene = bench_gpu.bench_scene("smooth", 2.0)

    def run_cpu(s):
        return simulate(s, philox_streams(5, 3))

    moved = run_cpu(dataclasses.replace(scene, storey_k=scene.storey_k * (1.0 + 3 * 2.0**-52)))
    assert not np.array_equal(moved, run_cpu(scene))  # the move reaches the outputs
    assert within_rounding(moved, scene, run_cpu) <= 1.0
    wrong = run_cpu(scene)
    wrong[_S["e1_max"]] *= 1.0 + 1e-6
    assert within_rounding(wrong, scene, run_cpu) > 1.0


def contact_noise(duration: float = 1.0):
    """Steel-on-steel Hertz contact beside a plastic impact NES under harmonic force and white
    noise: sticking, chatter and contact on the Brownian tree, in one loop."""
    return scene_from(example_data("contact_noise_parallel"), changes={"simulation.duration": duration})


@pytest.mark.parametrize(("name", "changes"), [
    ("seed003_ds20", {"simulation.duration": 40.0, "simulation.metrics_from": 0.0}),  # Hertz contact, RK4
    ("parallel_nes_impulse", {"simulation.duration": 20.0}),                          # impacts, RK4
])
def test_deterministic_scenes_give_the_cpu_metrics(name, changes):
    scene = scene_from(example_data(name, "sweep"), changes=changes)
    samples = sample_buffer(scene)
    cpu = simulate(scene, samples=samples)
    loop = kernel_for(scene, general=general_run(scene.n_steps))  # (the path's loop, ``start_path``)
    compiled = set(loop.overloads)
    batch = gpu.simulate_many(scene, seed=1, point=0, start=0, stop=3)
    assert compiled and set(loop.overloads) == compiled  # one loop for both (``kernels._UNUSED``)
    for raw, own in zip(batch.raw, batch.samples):
        np.testing.assert_allclose(own, samples, rtol=1e-9, atol=1e-12)  # Poincare samples (NaN where none)
        assert raw[_S["impacts"]] == cpu[_S["impacts"]]
        assert raw[_S["impacts_left"]] == cpu[_S["impacts_left"]]
        finite = np.isfinite(cpu)
        np.testing.assert_array_equal(np.isfinite(raw), finite)
        np.testing.assert_allclose(raw[finite], cpu[finite], rtol=1e-9, atol=1e-300)
    assert cpu[_S["impacts"]] > 0 or cpu[_S["contact_time"]] > 0  # the scene has events to get right
    assert (scene.period > 0) == (np.isfinite(samples).sum() > 0)


def test_a_noisy_realisation_is_the_cpu_loop_on_its_philox_streams():
    scene = contact_noise()
    batch = gpu.simulate_many(scene, seed=20261124, point=0, start=5, stop=9)
    impacts = 0.0
    for i, r in enumerate(range(5, 9)):
        cpu = simulate(scene, philox_streams(20261124, r))
        assert_cpu_loop(batch.raw[i], scene, lambda s, r=r: simulate(s, philox_streams(20261124, r)))
        impacts += cpu[_S["impacts"]] + cpu[_S["contact_time"]]
    assert impacts > 0
    assert len({float(row[_S["input_energy"]]) for row in batch.raw}) == 4  # four different paths


@pytest.mark.skipif(not gpu.simulating(), reason="the simulator's threads")
def test_the_simulated_threads_find_the_loop_compiled(monkeypatch):
    """The simulator's threads share the GIL with its busy-polling block manager: the step loop
    is compiled in the calling thread first (``gpu._compile_here``), and no simulated thread
    compiles it."""
    calls = []

    class Recording:
        """The loop, recording each call's thread and the specialisations it compiled."""

        def __init__(self, loop):
            self.loop = loop

        def __getattr__(self, name):
            return getattr(self.loop, name)

        def __call__(self, *args):
            before = len(self.loop.overloads)
            self.loop(*args)
            calls.append((threading.current_thread() is threading.main_thread(),
                          len(self.loop.overloads) - before))

    def recording(scene, gpu=False, general=False):
        return Recording(kernel_for(scene, gpu, general))

    monkeypatch.setattr(gpu, "kernel_for", recording)
    monkeypatch.setattr(kernels.paths, "kernel_for", recording)
    gpu.simulate_many(contact_noise(0.1), seed=2, point=0, start=0, stop=3)
    assert calls[0][0]  # the caller's thread ran the loop first
    assert [c for c in calls if not c[0]] == [(False, 0)] * 3  # three threads, none compiled


def test_batches_and_launch_sizes_change_nothing(monkeypatch):
    scene = contact_noise(0.5)
    whole = gpu.simulate_many(scene, seed=3, point=0, start=0, stop=7)
    monkeypatch.setattr(gpu, "SIMULATED_BATCH", 3)
    monkeypatch.setattr(gpu, "THREADS", 2)
    split = gpu.simulate_many(scene, seed=3, point=0, start=0, stop=7)
    np.testing.assert_array_equal(split.raw, whole.raw)
    tail = gpu.simulate_many(scene, seed=3, point=0, start=4, stop=7)  # another chunk boundary
    np.testing.assert_array_equal(tail.raw, whole.raw[4:])


def test_common_random_numbers_across_points_and_without():
    scene = contact_noise(0.5)
    p0 = gpu.simulate_many(scene, seed=3, point=0, start=0, stop=2)
    p1 = gpu.simulate_many(scene, seed=3, point=1, start=0, stop=2)
    np.testing.assert_array_equal(p0.raw, p1.raw)
    own = gpu.simulate_many(scene, seed=3, point=1, start=0, stop=2, common=False)
    assert not np.array_equal(own.raw[:, _S["input_energy"]], p0.raw[:, _S["input_energy"]])
    assert_cpu_loop(own.raw[1], scene, lambda s: simulate(s, philox_streams(3, 1, point=1, common=False)))


def filtered(duration: float = 2.0) -> dict:
    """The GPU bench's SSVI scene under its ground motion (from rest) and a filtered force from
    its stationary law (the bench's loop: no kernel of its own), with the intensity measures of
    the ground motion each realisation saw."""
    data = scene_data("ssvi")
    force = {**example_data("filtered_noise")["loads"][0], "intensity": 100.0}
    data["loads"] = [force, bench_gpu.GROUND_MOTION]
    return changed(data, {"simulation.duration": duration, "simulation.metrics_from": 0.0,
                          "intensity_measures": {"period": 1.0}})


def test_filtered_loads_start_from_their_stationary_law():
    scene = scene_from(filtered())
    assert scene.has_filters and scene.filters["p0"].any() and scene.has_ground
    batch = gpu.simulate_many(scene, seed=8, point=0, start=2, stop=4)
    for i, r in enumerate((2, 3)):
        assert_cpu_loop(batch.raw[i], scene, lambda s, r=r: simulate(s, philox_streams(8, r)))
    assert batch.raw[0, _S["input_energy"]] != batch.raw[1, _S["input_energy"]]


def test_history_rows_come_back():
    scene = scene_from(example_data("parallel_nes_impulse", "sweep"), changes={"simulation.duration": 5.0})
    history = np.full((11, 2), np.nan)
    simulate(scene, history=history, stride=100)
    batch = gpu.simulate_many(scene, seed=0, point=0, start=0, stop=2, grid=(100, 11))
    for rows in batch.history:
        np.testing.assert_allclose(rows, history, rtol=1e-12, atol=0.0)


def test_event_logs_come_back():
    """Each thread's event log is the CPU loop's on the same Philox streams (``assert_cpu_loop``)."""
    scene = contact_noise()
    batch = gpu.simulate_many(scene, seed=4, point=0, start=1, stop=3, events=40)
    assert batch.events.shape == (2, 40, 5)
    def log(s, r):
        events = new_events(40)
        simulate(s, philox_streams(4, r), events=events)
        return events

    for i, r in enumerate(range(1, 3)):
        assert_cpu_loop(batch.events[i], scene, lambda s, r=r: log(s, r))
    assert (np.isfinite(batch.events[:, :, 0]).sum(axis=1) > 1).all()


def test_declared_metrics_come_back():
    """A scene's declared metrics (``[output] metrics``: the contact forces among them, whose
    impulses each thread keeps on its stack) fill each thread's metric row as the CPU loop's on
    the same Philox streams (``assert_cpu_loop``)."""
    metrics = ["stroke_1_peak", "va_2_rms", "contact_1_peak", "contact_2_peak"]
    scene = scene_from(example_data("contact_noise_parallel"),
                       changes={"simulation.duration": 1.0, "output.metrics": metrics})
    batch = gpu.simulate_many(scene, seed=4, point=0, start=1, stop=3)
    for i, r in enumerate(range(1, 3)):
        assert_cpu_loop(batch.raw[i], scene, lambda s, r=r: simulate(s, philox_streams(4, r)))
    assert (batch.raw[:, -8] > 0).all()  # (stroke_1_peak's slot)
    assert (batch.raw[:, -2] > 0).all()  # (contact_2_peak's: the impact absorber's impulses)


def test_uncertain_parameters_run_a_scene_a_realisation():
    base = example_data("parallel_nes_impulse", "sweep")
    scenes = [scene_from(base, changes={"simulation.duration": 5.0, "absorbers.0.stiffness": k})
              for k in (0.5, 1.0, 2.0)]
    batch = gpu.simulate_many(scenes, seed=0, point=0, start=0, stop=3)
    for raw, scene in zip(batch.raw, scenes):
        np.testing.assert_allclose(raw, simulate(scene), rtol=1e-12, atol=0.0)
    with pytest.raises(ValueError, match="2 scenes for 3 realisations"):
        gpu.simulate_many(scenes[:2], seed=0, point=0, start=0, stop=3)


#: The noisy two-absorber study of the ensemble tests, shorter.
ENSEMBLE = changed(DATA, {"name": "gpu-ensemble", "simulation.duration": 2.0, "ensemble.realizations": 30})


def test_gpu_and_cpu_ensembles_sample_the_same_law():
    """The noisy two-absorber scene: the mean squared displacement and input energy of both
    ensembles agree within four standard errors of their difference."""
    scene = scene_from(ENSEMBLE)
    n = 200
    gpu_rows = gpu.simulate_many(scene, seed=11, point=0, start=0, stop=n).raw
    cpu_rows = np.array([simulate(scene, streams(11, 0, r)) for r in range(n)])
    for slot in ("x1_square_integral", "input_energy"):
        a, b = gpu_rows[:, _S[slot]], cpu_rows[:, _S[slot]]
        se = math.sqrt(a.var(ddof=1) / n + b.var(ddof=1) / n)
        assert abs(a.mean() - b.mean()) < 4.0 * se
        assert not np.array_equal(a, b)  # two independent samples (different streams)


def test_a_cuda_run_writes_the_cpu_tables_from_its_own_streams(tmp_path):
    study = study_from(ENSEMBLE)
    realizations, summary = run(study, tmp_path / "gpu", backend="cuda", chunk=7)
    cpu, _ = run(study, tmp_path / "cpu")
    assert list(realizations.columns) == list(cpu.columns)
    assert len(realizations) == 60 and list(summary["n_ok"]) == [30, 30]
    # the scene runs in SIMD lanes on the CPU: the CPU draws from the same Philox streams, and each
    # CPU row is the loop on them (as each GPU row: the rows of point 1 below)
    if gpu.simulating():
        pd.testing.assert_frame_equal(realizations, cpu, check_exact=True)
    assert "cuda" in read_metadata(tmp_path / "gpu" / "realizations.parquet")["vines_stoch.scheduler"]
    # a realisation's row is its loop run on its Philox streams, whatever the chunk
    scene = scene_from(ENSEMBLE, point=1)
    row = realizations[(realizations["point"] == 1) & (realizations["realization"] == 9)].iloc[0]
    slots = [_S["input_energy"], _S["impacts"]]
    assert_cpu_loop(row[["input_energy", "impacts"]].to_numpy(float), scene,
                    lambda s: simulate(s, philox_streams(11, 9))[slots])
    again, _ = run(study, tmp_path / "gpu-whole", backend="cuda")
    pd.testing.assert_frame_equal(again, realizations, check_exact=True)


def test_a_cuda_run_writes_its_event_logs(tmp_path):
    study = study_from(changed(ENSEMBLE, {"output.events": 10_000, "ensemble.realizations": 6}))
    results = run(study, tmp_path, backend="cuda")
    events, realizations = results.events, results.realizations
    assert len(events) == realizations["impacts"].sum() > 0
    counts = events.groupby(["point", "realization"]).size()
    for (point, r), n in counts.items():
        row = realizations[(realizations["point"] == point) & (realizations["realization"] == r)].iloc[0]
        assert n == row["impacts"]


def test_a_cuda_run_resumes_only_its_own_parts(tmp_path):
    study = study_from(ENSEMBLE)
    first, _ = run(study, tmp_path, backend="cuda", chunk=10)
    parts = sorted((tmp_path / "parts").glob("point*.parquet"))
    parts[-1].unlink()  # an interrupted run
    resumed, _ = run(study, tmp_path, backend="cuda", chunk=10, resume=True)
    pd.testing.assert_frame_equal(resumed, first, check_exact=True)
    with pytest.raises(ValueError, match="different scenario or chunk plan"):
        run(study, tmp_path, chunk=10, resume=True)  # the CPU's streams are another run's


def test_target_sem_and_history_statistics_on_the_cuda_backend(tmp_path):
    data = changed(ENSEMBLE, {"ensemble.realizations": 400, "ensemble.target_sem": 1.0,
                              "simulation.history": {"points": 11}})
    realizations, _ = run(study_from(data), tmp_path, backend="cuda", chunk=150)
    assert set(realizations.groupby("point").size()) == {100}  # stopped at the first test
    history = pd.read_parquet(tmp_path / "history.parquet")
    assert len(history) == 2 * 11 and history["x1_mean"].notna().all()


def test_uncertain_parameters_and_intensity_measures_on_the_cuda_backend(tmp_path):
    single = {k: v for k, v in ENSEMBLE.items() if k != "sweep"}
    law = {"distribution": "lognormal", "median": 1.0, "cov": 0.3}
    data = changed(single, {"ensemble.realizations": 6, "uncertain": {"absorbers.0.stiffness": law}})
    realizations, _ = run(study_from(data), tmp_path / "u", backend="cuda")
    cpu, _ = run(study_from(data), tmp_path / "c")
    # the drawn values come from the CPU's parameter streams on both backends
    np.testing.assert_array_equal(realizations["absorbers.0.stiffness"], cpu["absorbers.0.stiffness"])
    assert realizations["absorbers.0.stiffness"].nunique() == 6
    ground = study_from(changed(filtered(), {"ensemble.realizations": 3}))
    rows, _ = run(ground, tmp_path / "g", backend="cuda")
    # the intensity measures of the ground path each realisation saw: the host replays its filter stream
    assert rows["sa"].notna().all() and rows["pga"].nunique() == 3 and (rows["pga"] > 0).all()


def test_cuda_backend_without_a_gpu_is_a_clear_error(tmp_path, write):
    scenario = write((ROOT / "scenarios" / "parallel_nes_noise.toml").read_text())
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_ENABLE_CUDASIM"}
    if gpu.unavailable() is None and not gpu.simulating():
        pytest.skip("a GPU is present")
    done = subprocess.run([sys.executable, "-m", "vines_stoch.cli", "run", str(scenario), "--backend", "cuda",
                           "--out", str(tmp_path / "out")], capture_output=True, text=True, env=env,
                          timeout=300)
    assert done.returncode == 2
    assert "error: --backend cuda:" in done.stderr and "Traceback" not in done.stderr
    assert not (tmp_path / "out").exists()
    code, err = cli("run", str(scenario), "--backend", "tpu")
    assert code == 2 and "--backend tpu: must be one of cpu, cuda" in err


def test_numpy_without_row_stack_is_a_clear_reason(monkeypatch):
    """numba-cuda 0.30's GPU target names ``np.row_stack`` (gone in numpy 2.5) when it loads: a
    GPU run there would stop in numba-cuda's import; ``gpu.unavailable`` names the cause."""
    from numba import cuda
    from numba.cuda.cudadrv import nvvm

    monkeypatch.setattr(gpu, "simulating", lambda: False)
    monkeypatch.setattr(cuda, "is_available", lambda: True)
    monkeypatch.setattr(cuda, "gpus", [object()], raising=False)
    monkeypatch.setattr(nvvm, "is_available", lambda: True)
    monkeypatch.setattr(np, "row_stack", np.vstack, raising=False)
    assert gpu.unavailable() is None
    monkeypatch.delattr(np, "row_stack")
    assert "numba-cuda 0.30 needs numpy < 2.5" in gpu.unavailable()


def test_paths_run_in_stretches_on_the_gpu_are_the_cpu_loop():
    """``gpu.advance_many``: a batch of paths (impacts; one a thread, each from its own step to
    its own stop, then on to the end) ends where the CPU loop run in the same stretches on the
    same Philox streams ends, and so does a path that replays its white noise and its filters'
    normals from a tape (subset simulation's)."""
    from tests.unit.statistics.test_rare import filtered_oscillator, impact_oscillator
    from vines_stoch.kernels import advance, filter_draws, start_path
    from vines_stoch.streams.rng import tape

    scene = scene_from(impact_oscillator(3.0))
    firsts = [50, 60, 0, 100, 200]

    def cpu_run(s, r):
        path = start_path(s, philox_streams(7, r))
        advance(path, firsts[r])
        return advance(path, s.n_steps).out

    paths = [start_path(scene, philox_streams(7, r)) for r in range(5)]
    gpu.advance_many(paths, firsts)
    assert [p.step for p in paths] == firsts
    gpu.advance_many(paths, [scene.n_steps] * 5)
    for r, path in enumerate(paths):
        assert_cpu_loop(path.out, scene, lambda s, r=r: cpu_run(s, r))
    assert sum(p.out[_S["impacts"]] for p in paths) > 0

    noisy = scene_from(changed(filtered_oscillator(3.0), {"simulation.duration": 1.0}) | {
        "loads": [{"type": "filtered-noise", "intensity": 170.0, "frequency": 6.0, "damping": 0.3},
                  {"type": "white-noise", "intensity": 3.0}]})
    inputs = np.random.default_rng(3).standard_normal((3, noisy.n_steps + filter_draws(noisy)))

    def replayed(s, u):
        streams = Streams(keyed_stream(0, 0), None, tape(u[s.n_steps:]))
        return start_path(s, streams, normals=u[:s.n_steps], stretches=False)

    paths = [replayed(noisy, u) for u in inputs]
    gpu.advance_many(paths, [noisy.n_steps] * 3)
    for path, u in zip(paths, inputs):
        assert_cpu_loop(path.out, noisy, lambda s, u=u: advance(replayed(s, u), s.n_steps).out)


def test_rare_estimates_and_sobol_indices_on_the_cuda_backend():
    """The rare-event estimates and the Sobol design run their paths on the GPU: both methods
    against the oscillator's exact first-passage probability at about 4e-3 (within ``Z``
    standard errors, the estimates' reported ``cov``), and the indices of a parameter that
    cannot matter exactly 0."""
    from tests.unit.statistics.test_rare import agree, oscillator
    from tests.unit.statistics.test_sensitivity import scene_data
    from vines_stoch import rare
    from vines_stoch.validation.first_passage import isee, response_matrix

    data = oscillator(2.8, duration=2.0)
    reference, se = isee(response_matrix(scene_from(data)), 2.8)
    assert 1e-3 < reference < 1e-2
    results = run(data | {"rare": {"limit": "roof", "method": "subset", "particles": 200, "target_cov": 0.2,
                                   "max_paths": 20_000}}, backend="cuda")
    row = results.rare.iloc[0]
    assert agree(row["p"], row["cov"], reference, se), (row["p"], row["cov"], reference)
    scene = scene_from(data)
    split = rare.estimate(lambda j: scene, 0, "splitting", 5, 0, particles=20, target_cov=0.5, max_paths=1e9,
                          replicas=5, backend="cuda")
    assert agree(split.p, split.cov, reference, se), (split.p, split.cov, reference)
    sobol = run(changed(scene_data(), {"sensitivity.samples": 16}), backend="cuda").sensitivity
    dead = sobol.set_index("parameter").loc["absorbers.0.mass"]
    assert dead.st == 0.0 and dead.s1 == 0.0
