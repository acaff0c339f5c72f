"""Ensembles: bitwise reproducibility across chunk sizes and thread counts; Parquet contract."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from tests.helpers import cli, study_from, toml_text
from vines_stoch import load_scenario, read_results, run, solve
from vines_stoch.ensemble import sample
from vines_stoch.kernels import EXECUTORS, realization_streams, simulate
from vines_stoch.metrics import METRICS, finish_table
from vines_stoch.scene import build_scene
from vines_stoch.store import read_metadata

DATA = {
    "name": "repro",
    "primary": {"mass": 1.0, "stiffness": 1.0},
    "absorbers": [{"type": "cubic", "mass": 0.05, "stiffness": 1.0, "damping": 0.01},
                  {"type": "impact", "mass": 0.05, "clearance": 0.2, "restitution": 0.6}],
    "loads": [{"type": "harmonic", "amplitude": 0.1, "frequency": 1.0},
              {"type": "white-noise", "intensity": 0.1}],
    "simulation": {"duration": 5.0, "dt": 1e-3},
    "ensemble": {"realizations": 23, "seed": 11},
    "sweep": {"loads.1.intensity": [0.05, 0.1]},
}

METRIC_COLUMNS = ["point", "realization", "loads.1.intensity", *METRICS, "status"]


def test_bitwise_identical_for_any_chunk_and_thread_count(tmp_path):
    study = study_from(DATA)
    frames = []
    for i, (chunk, workers) in enumerate([(1, 1), (7, 2), (0, 2), (0, 1)]):
        realizations, _ = run(study, tmp_path / str(i), chunk=chunk, workers=workers)
        frames.append(realizations[METRIC_COLUMNS])
    for other in frames[1:]:
        pd.testing.assert_frame_equal(frames[0], other, check_exact=True)
    assert frames[0]["edm"].nunique() == len(frames[0])  # every realisation has its own stream


def test_results_contract(tmp_path):
    study = study_from(DATA)
    run(study, tmp_path)
    realizations, summary = read_results(tmp_path)
    assert len(realizations) == 2 * 23 and set(METRIC_COLUMNS) <= set(realizations.columns)
    assert (realizations["status"] == "ok").all()
    assert list(summary["loads.1.intensity"]) == [0.05, 0.1]
    assert (summary["n_ok"] == 23).all() and (summary["n_failed"] == 0).all()
    for m in METRICS:
        for stat in ("mean", "std", "sem", "q05", "q50", "q95"):
            assert f"{m}_{stat}" in summary.columns
    group = realizations[realizations["point"] == 1]["edm"]
    assert summary.loc[1, "edm_mean"] == pytest.approx(group.mean(), rel=1e-14)
    assert summary.loc[1, "edm_sem"] == pytest.approx(group.std(ddof=1) / 23**0.5, rel=1e-12)
    meta = read_metadata(tmp_path / "summary.parquet")
    assert meta["vines_stoch.scenario"] == study.text and meta["vines_stoch.seed"] == "11"
    assert "numba" in meta["vines_stoch.dependencies"]


def test_resume_keeps_finished_chunks(tmp_path):
    study = study_from(DATA)
    first, _ = run(study, tmp_path, chunk=5)
    parts = sorted((tmp_path / "parts").glob("*.parquet"))
    parts[-1].unlink()  # as if interrupted before the last chunk
    kept = parts[0].stat().st_mtime_ns
    again, _ = run(study, tmp_path, chunk=5, resume=True)
    assert parts[0].stat().st_mtime_ns == kept
    pd.testing.assert_frame_equal(first, again, check_exact=True)


EXAMPLES = ["parallel_nes_impulse", "cubic_nes_impulse", "parallel_nes_noise", "filtered_noise",
            "half_sine_shock", "pulse_train", "chirp", "synthetic_record", "ground_motion", "elcentro",
            "robustness_parallel", "robustness_cubic", "seed003_ss_ground_motion", "seed003_ds_ground_motion",
            "seed003_harmonic_noise", "contact_noise_parallel", "wind_nine_storey"]


@pytest.mark.parametrize("name", EXAMPLES)
def test_example_scenarios_close_the_energy_balance(tmp_path, name):
    """Every load type in an example scenario, Hertz contact under noise (steel on steel
    included): energy_residual < 1e-3 in every realisation."""
    path = f"scenarios/{name}.toml"
    if name == "elcentro" and not Path("scenarios/records/elcentro_1940_ns.txt").is_file():
        pytest.skip("the El Centro record is fetched by `make elcentro`")
    study = load_scenario(path)
    # the residual is per realisation: a few realisations of each point check the balance
    realizations, summary = run(study, tmp_path, realizations=8)
    assert (realizations["status"] == "ok").all()
    assert realizations["energy_residual"].abs().max() < 1e-3


def test_automatic_chunks_of_lane_scenes_are_batches_of_lanes_and_contact_counts_at_its_cost():
    """``ensemble.plan``: a smooth scene in SIMD lanes takes whole batches of lanes, evened out
    (200 paths of 200,000 steps: two chunks of 100); a scene with Hertz contact, whose steps in contact are
    finished by the scalar step, is split by its scalar cost, so that two workers share 256
    paths of 20,000 steps (two chunks of a lane batch each)."""
    from tests.helpers import ROOT
    from vines_stoch.ensemble import plan
    from vines_stoch.kernels.lanes import LANES
    from vines_stoch.validation import scenes

    smooth = scenes.study("smooth", {"ensemble.realizations": 200, "simulation.duration": 200.0})
    assert [(c[1], c[2]) for c in plan(smooth).chunks] == [(0, 100), (100, 200)]
    contact = load_scenario(ROOT / "scenarios" / "contact_noise_parallel.toml")
    data = {key: value for key, value in contact.data.items() if key != "sweep"}
    one = scenes.study(data, {**contact.grid[0], "ensemble.realizations": 256, "simulation.duration": 20.0},
                       directory=contact.directory)
    assert [(c[1], c[2]) for c in plan(one).chunks] == [(0, LANES), (LANES, 256)]


def test_automatic_chunks_count_at_the_cost_of_the_loop_that_runs_them():
    """A lane scene keeps its history rows in the lanes, so ``ensemble.plan`` sizes its chunks at
    the lanes' cost (200 paths of 200,000 steps: two chunks of 100, the history's buffer within
    ``HISTORY_CHUNK_BYTES``), as without them, and so do an event log and declared metrics; the
    scalar executor's chunks count its cost (200 / CHUNKS_PER_POINT paths, rounded up)."""
    import math

    from vines_stoch.ensemble import CHUNKS_PER_POINT, plan
    from vines_stoch.kernels.chunk import lane_scene
    from vines_stoch.scene import build_scene
    from vines_stoch.validation import scenes

    changes = {"ensemble.realizations": 200, "simulation.duration": 200.0}
    lanes = scenes.study("smooth", changes)
    kept = scenes.study("smooth", {**changes, "simulation.history": True})
    logged = scenes.study("smooth_impact", {**changes, "output.events": 100, "output.metrics": ["x_1_rms"]})
    assert lane_scene(build_scene(kept.points[0])) and lane_scene(build_scene(logged.points[0]))
    assert len(plan(lanes).chunks) == 2 and len(plan(kept).chunks) == 2 and len(plan(logged).chunks) == 2
    scalar = plan(logged, executor="scalar").chunks
    assert {c[2] - c[1] for c in scalar[:-1]} == {math.ceil(200 / CHUNKS_PER_POINT)}


def test_the_executor_is_an_argument_of_the_run():
    """``executor="scalar"`` runs the scalar loop on the PCG64 streams of ``streams.streams``: a
    realisation's row is ``simulate``'s on those streams, bitwise; the lanes draw from other
    streams.  Runs of the two executors side by side, in two threads of one process, each give
    the numbers they give alone (the executor is the run's, not a process-wide switch)."""
    from concurrent.futures import ThreadPoolExecutor

    study = study_from(DATA)

    def table(executor: str) -> pd.DataFrame:
        return run(study, None, workers=1, executor=executor).realizations[METRIC_COLUMNS]

    alone = {executor: table(executor) for executor in EXECUTORS}
    assert (alone["lanes"]["edm"].to_numpy() != alone["scalar"]["edm"].to_numpy()).all()
    point, r = 1, 5
    scene = build_scene(study.points[point])
    gens = realization_streams(scene, study.base.ensemble.seed, point, r, executor="scalar")
    assert isinstance(gens.increments, np.random.Generator)  # (PCG64, not a Philox stream)
    row = finish_table(simulate(scene, gens)[None, :], scene)
    got = alone["scalar"][(alone["scalar"]["point"] == point) & (alone["scalar"]["realization"] == r)]
    assert got["edm"].item() == row["edm"].item() and got["impacts"].item() == row["impacts"].item()
    with ThreadPoolExecutor(2) as pool:
        together = dict(zip(EXECUTORS, pool.map(table, EXECUTORS)))
    for executor in EXECUTORS:
        pd.testing.assert_frame_equal(together[executor], alone[executor], check_exact=True)


def test_solve_sample_and_the_command_line_take_the_executor(tmp_path):
    """``solve``, ``sample`` and ``vines-stoch run --executor`` give, bitwise, the rows ``run``
    gives with the same executor; the command line's folder says which loop ran."""
    data = {**DATA, "ensemble": {"realizations": 6, "seed": 11}}
    study = study_from(data)
    scenario = tmp_path / "s.toml"
    scenario.write_text(toml_text(data))
    for executor in EXECUTORS:
        rows = run(study, None, workers=1, executor=executor).realizations
        sampled = sample(study, workers=1, executor=executor)
        assert (sampled["edm"].to_numpy() == rows["edm"].to_numpy()).all()
        got = solve(study, point=1, realization=4, points=11, executor=executor).metrics
        row = rows[(rows["point"] == 1) & (rows["realization"] == 4)]
        assert got["edm"] == row["edm"].item() and got["impacts"] == row["impacts"].item()
        out = tmp_path / executor
        assert cli("run", scenario, "--out", out, "--quiet", "--workers", "1", "--executor", executor)[0] == 0
        written, _ = read_results(out)
        assert (written["edm"].to_numpy() == rows["edm"].to_numpy()).all()
        assert ("scalar loop" in read_metadata(out / "summary.parquet")["vines_stoch.scheduler"]) == (
            executor == "scalar")
    code, err = cli("run", scenario, "--out", tmp_path / "x", "--quiet", "--executor", "simd")
    assert code != 0 and "executor = 'simd'" in err


@pytest.mark.parametrize("executor, backend", [("simd", "cpu"), (None, "cpu"), ("scalar", "cuda")])
def test_a_wrong_executor_is_named(executor, backend):
    with pytest.raises(ValueError, match=rf"executor = {executor!r}: .*'lanes'"):
        run(study_from(DATA), None, executor=executor, backend=backend)
