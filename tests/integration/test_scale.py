"""Ensembles at scale: history statistics, target_sem, resume after SIGKILL or interruption,
dask.distributed with a worker killed mid-run."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time

import numpy as np
import pandas as pd
import pytest
from scipy.stats import t as student_t

from tests.helpers import cli, run_interrupted, study_from, toml_text, two_dof_data
from vines_stoch import ensemble, history, run
from vines_stoch.kernels import DEFAULT_SIGNALS, simulate
from vines_stoch.kernels.chunk import realization_streams
from vines_stoch.scene import build_scene
from vines_stoch.store import read_metadata


def scenario(n: int = 60, chunk: int = 0, duration: float = 5.0, dt: float = 1e-2, history: bool = True,
             **ensemble) -> dict:
    """The two-body scene under white noise, ``n`` realisations in chunks of ``chunk``, with
    history statistics (or without: ``history=False``); ``ensemble``: more keys of its table."""
    simulation: dict = {"duration": duration, "dt": dt}
    if history:
        simulation["history"] = {"points": 51, "quantiles": [0.05, 0.5, 0.95]}
    return {"name": "scale", **two_dof_data(), "loads": [{"type": "white-noise", "intensity": 0.1}],
            "simulation": simulation, "ensemble": {"realizations": n, "seed": 7, "chunk": chunk, **ensemble}}


def stored_paths(study, n: int) -> tuple[np.ndarray, np.ndarray]:
    """x1 and E1 paths of realisations 0..n-1 on the history grid, stored: ``(2, grid, n)``."""
    scene = build_scene(study.points[0])
    stride, size = history.grid(scene.n_steps, study.base.simulation.history.points)
    paths = np.empty((2, size, n))
    for r in range(n):
        path = np.full((size, 2), np.nan)
        gens = realization_streams(scene, study.base.ensemble.seed, 0, r)
        simulate(scene, gens, history=path, stride=stride)
        paths[:, :, r] = path.T
    return paths, scene.dt * stride * np.arange(size)


def test_history_equals_statistics_of_stored_paths(tmp_path):
    """Small ensemble (n <= BLOCK): moments to round-off, quantiles exactly numpy's."""
    study = study_from(scenario(n=60, chunk=7))
    run(study, tmp_path, workers=2)
    h = pd.read_parquet(tmp_path / "history.parquet")
    paths, t = stored_paths(study, 60)
    np.testing.assert_array_equal(h["t"], t)
    assert (h["n"] == 60).all() and (h["rank_error"] == 0).all()
    for s, name in enumerate(DEFAULT_SIGNALS):
        np.testing.assert_allclose(h[f"{name}_mean"], paths[s].mean(axis=1), rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(h[f"{name}_std"], paths[s].std(axis=1, ddof=1), rtol=1e-11, atol=1e-15)
        for q in (0.05, 0.5, 0.95):
            np.testing.assert_array_equal(h[f"{name}_q{int(round(q * 100)):02d}"],
                                          np.quantile(paths[s], q, axis=1))


def test_history_tree_is_chunk_invariant_and_within_its_rank_bound(tmp_path, monkeypatch):
    """With leaves of 16 the tree merges and compacts many times: moments stay exact, the
    frame is bitwise the same for any chunk size and thread count, and every quantile lies
    within the reported rank-error bound of the exact one."""
    monkeypatch.setattr(history, "BLOCK", 16)
    n = 300
    frames = []
    for i, (chunk, workers) in enumerate([(0, 2), (1, 1), (7, 2), (64, 2)]):
        run(study_from(scenario(n=n, chunk=chunk)), tmp_path / str(i), workers=workers)
        frames.append(pd.read_parquet(tmp_path / str(i) / "history.parquet"))
    for other in frames[1:]:
        pd.testing.assert_frame_equal(frames[0], other, check_exact=True)
    h = frames[0]
    paths, _ = stored_paths(study_from(scenario(n=n)), n)
    bound = h["rank_error"].iloc[0]
    assert 0 < bound < 0.25
    for s, name in enumerate(DEFAULT_SIGNALS):
        np.testing.assert_allclose(h[f"{name}_mean"], paths[s].mean(axis=1), rtol=1e-11, atol=1e-15)
        np.testing.assert_allclose(h[f"{name}_std"], paths[s].std(axis=1, ddof=1), rtol=1e-10, atol=1e-15)
        for q in (0.05, 0.5, 0.95):
            estimate = h[f"{name}_q{int(round(q * 100)):02d}"].to_numpy()[1:]  # t = 0 is a point mass
            below = (paths[s][1:] < estimate[:, None]).mean(axis=1)
            at_most = (paths[s][1:] <= estimate[:, None]).mean(axis=1)
            assert (below <= q + bound + 1.0 / n).all() and (at_most >= q - bound - 1.0 / n).all()


def test_history_memory_does_not_grow_with_realisations(monkeypatch):
    """The tree keeps at most one node per level and one open leaf: buffered values grow like
    BLOCK log2(n / BLOCK), not like n."""
    monkeypatch.setattr(history, "BLOCK", 16)
    tree = history.Tree()
    rng = np.random.default_rng(0)
    for _ in range(64):
        tree.add(rng.standard_normal((2, 3, 100)), np.ones(100, bool))
    buffered = sum(node.values.shape[2] for node in tree.levels.values())
    assert tree.seen == 6400 and len(tree.levels) <= 9 and buffered <= 16 * 9
    node = tree.result()
    assert node.count == 6400 and node.values.shape[2] <= 16


def test_target_sem_stops_at_a_multiple_of_the_step_whatever_the_chunks(tmp_path):
    results = []
    for i, chunk in enumerate([0, 37]):
        study = study_from(scenario(n=2000, chunk=chunk, history=False, target_sem=0.004))
        realizations, summary = run(study, tmp_path / str(i), workers=2)
        results.append(realizations)
    pd.testing.assert_frame_equal(results[0], results[1], check_exact=True)
    n = len(results[0])
    assert n % ensemble.TARGET_STEP == 0 and ensemble.TARGET_STEP < n < 2000
    assert (results[0]["realization"] == np.arange(n)).all()
    edm = results[0]["edm"].to_numpy()
    sem = lambda m: edm[:m].std(ddof=1) / np.sqrt(m)  # noqa: E731
    assert sem(n) <= 0.004 < sem(n - ensemble.TARGET_STEP)


def test_summary_confidence_interval(tmp_path):
    _, summary = run(study_from(scenario(n=40, history=False)), tmp_path, workers=1)
    row = summary.iloc[0]
    half = student_t.ppf(0.975, row["n_ok"] - 1) * row["edm_sem"]
    assert row["edm_ci95_lo"] == pytest.approx(row["edm_mean"] - half, rel=1e-12)
    assert row["edm_ci95_hi"] == pytest.approx(row["edm_mean"] + half, rel=1e-12)
    assert row["edm_sem"] == pytest.approx(row["edm_std"] / np.sqrt(40), rel=1e-12)


def test_interrupted_run_resumes_history_from_its_checkpoint(tmp_path, monkeypatch):
    """An interruption after some chunks (checkpoint after every fold) and --resume give the
    same realisations and history as an uninterrupted run."""
    monkeypatch.setattr(history, "BLOCK", 8)
    study = study_from(scenario(n=120, chunk=5))
    reference = run(study, tmp_path / "ref", workers=2)
    ref_history = pd.read_parquet(tmp_path / "ref" / "history.parquet")

    run_interrupted(monkeypatch, study, tmp_path / "cut", 10, workers=2)
    assert (tmp_path / "cut" / "parts" / "history.npz").exists()
    assert not (tmp_path / "cut" / "realizations.parquet").exists()
    resumed = run(study, tmp_path / "cut", workers=2, resume=True)
    pd.testing.assert_frame_equal(reference[0], resumed[0], check_exact=True)
    pd.testing.assert_frame_equal(ref_history, pd.read_parquet(tmp_path / "cut" / "history.parquet"),
                                  check_exact=True)


def spawn(*args: str) -> subprocess.Popen:
    """``vines-stoch ARGS`` as a process of its own."""
    return subprocess.Popen([sys.executable, "-m", "vines_stoch.cli", *args], stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, text=True)


def test_sigkill_midway_then_resume_is_bitwise_identical(tmp_path):
    """A real process is killed with SIGKILL after a few chunks; --resume completes the run and
    realizations.parquet is byte for byte the uninterrupted run's (run in this process)."""
    path = tmp_path / "kill.toml"
    path.write_text(toml_text(scenario(n=240, chunk=3, duration=60.0, dt=1e-3, history=False)))
    code, err = cli("run", str(path), "--out", str(tmp_path / "ref"), "--workers", "1", "--quiet")
    assert code == 0, err

    victim = spawn("run", str(path), "--out", str(tmp_path / "cut"), "--workers", "1", "--quiet")
    parts = tmp_path / "cut" / "parts"
    deadline = time.monotonic() + 300
    while (len(list(parts.glob("point*.parquet"))) < 5 and victim.poll() is None
           and time.monotonic() < deadline):
        time.sleep(0.01)
    victim.send_signal(signal.SIGKILL)
    victim.wait(timeout=60)
    finished = len(list(parts.glob("point*.parquet")))
    assert victim.returncode == -signal.SIGKILL
    assert 5 <= finished < 80 and not (tmp_path / "cut" / "realizations.parquet").exists()

    resumed = spawn("run", str(path), "--out", str(tmp_path / "cut"), "--workers", "1", "--quiet", "--resume")
    assert resumed.wait(timeout=600) == 0, resumed.stderr.read()
    cut, ref = tmp_path / "cut" / "realizations.parquet", tmp_path / "ref" / "realizations.parquet"
    assert cut.read_bytes() == ref.read_bytes()


def test_distributed_cluster_survives_a_killed_worker(tmp_path):
    """Two worker processes on loopback; one is killed with SIGKILL mid-run; the run completes
    with realisations and history identical to the embedded scheduler's."""
    from dask.distributed import Client, LocalCluster

    study = study_from(scenario(n=160, chunk=2, duration=100.0, dt=1e-3))
    embedded = run(study, tmp_path / "embedded", workers=2)
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                      host="127.0.0.1") as cluster, Client(cluster) as client:
        client.run(lambda: None)  # workers up
        result: dict = {}
        worker = threading.Thread(target=lambda: result.update(
            frames=run(study, tmp_path / "distributed", scheduler=cluster.scheduler_address)))
        worker.start()
        parts = tmp_path / "distributed" / "parts"
        deadline = time.monotonic() + 300
        while len(list(parts.glob("point*.parquet"))) < 4 and time.monotonic() < deadline:
            time.sleep(0.01)
        pids = client.run(os.getpid)
        killed = len(list(parts.glob("point*.parquet")))
        os.kill(next(iter(pids.values())), signal.SIGKILL)
        worker.join(timeout=600)
    assert killed < 80, "the run finished before a worker could be killed"
    distributed = result["frames"]
    pd.testing.assert_frame_equal(embedded[0], distributed[0], check_exact=True)
    pd.testing.assert_frame_equal(embedded[1], distributed[1], check_exact=True)
    pd.testing.assert_frame_equal(pd.read_parquet(tmp_path / "embedded" / "history.parquet"),
                                  pd.read_parquet(tmp_path / "distributed" / "history.parquet"),
                                  check_exact=True)
    meta = read_metadata(tmp_path / "distributed" / "realizations.parquet")
    assert meta["vines_stoch.scheduler"] == f"dask.distributed at {cluster.scheduler_address}"
    embedded_meta = read_metadata(tmp_path / "embedded" / "realizations.parquet")
    assert embedded_meta["vines_stoch.scheduler"] == "embedded"


def test_scheduler_file(tmp_path):
    """``--scheduler-file``: the JSON a ``dask scheduler --scheduler-file`` writes names the
    scheduler; the run is the embedded run's, its metadata and standard error name the
    cluster (and its dashboard)."""
    import json

    from dask.distributed import LocalCluster

    path = tmp_path / "s.toml"
    path.write_text(toml_text(scenario(n=8, chunk=2)))
    code, err = cli("run", path, "--out", tmp_path / "embedded", "--quiet", "--workers", "1")
    assert code == 0, err
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=":0",
                      host="127.0.0.1") as cluster:
        file = tmp_path / "scheduler.json"
        file.write_text(json.dumps({"address": cluster.scheduler_address}))
        code, err = cli("run", path, "--out", tmp_path / "cluster", "--scheduler-file", file)
        assert code == 0, err
        assert f"dask.distributed at {cluster.scheduler_address}, dashboard http" in err
    meta = read_metadata(tmp_path / "cluster" / "realizations.parquet")
    assert meta["vines_stoch.scheduler"] == f"dask.distributed at {cluster.scheduler_address}"
    pd.testing.assert_frame_equal(pd.read_parquet(tmp_path / "embedded" / "realizations.parquet"),
                                  pd.read_parquet(tmp_path / "cluster" / "realizations.parquet"),
                                  check_exact=True)
    code, err = cli("run", path, "--scheduler-file", tmp_path / "missing.json")
    assert code == 2 and "no such file" in err


def test_shards_then_resume_give_the_one_run(tmp_path):
    """A study split with ``--shard 0/2`` and ``--shard 1/2`` (each runs every other chunk into
    the same folder, no results) and then ``--resume`` gives byte for byte the results of one
    run; shards share the folder with each other but not with a whole run; history studies
    are refused."""
    path = tmp_path / "s.toml"
    path.write_text(toml_text(scenario(n=24, chunk=2, history=False)))
    one, split = tmp_path / "one", tmp_path / "split"
    assert cli("run", path, "--out", one, "--quiet", "--workers", "1")[0] == 0
    code, err = cli("run", path, "--out", split, "--workers", "1", "--shard", "0/2")
    assert code == 0 and "once every shard has finished" in err, err
    assert not (split / "realizations.parquet").exists()
    assert len(list((split / "parts").glob("point*.parquet"))) == 6  # 12 chunks, every other one
    assert cli("run", path, "--out", split, "--quiet", "--workers", "1", "--shard", "1/2")[0] == 0
    assert len(list((split / "parts").glob("point*.parquet"))) == 12
    assert cli("run", path, "--out", split, "--quiet", "--workers", "1", "--resume")[0] == 0
    for name in ("realizations.parquet", "summary.parquet"):
        assert (split / name).read_bytes() == (one / name).read_bytes()
    assert cli("run", path, "--out", split, "--shard", "2/2")[0] == 2
    with_history = tmp_path / "h.toml"
    with_history.write_text(toml_text(scenario(n=4)))
    code, err = cli("run", with_history, "--out", tmp_path / "h", "--shard", "0/2")
    assert code == 2 and "history statistics" in err


def test_shard_locks_share_a_folder_with_each_other_only(tmp_path):
    from vines_stoch.store import FolderInUse, lock_folder

    with lock_folder(tmp_path, "shard-0-of-2"), lock_folder(tmp_path, "shard-1-of-2"):
        with pytest.raises(FolderInUse, match="in use by the shard-0-of-2 run"):
            with lock_folder(tmp_path):
                pass
    with lock_folder(tmp_path):
        with pytest.raises(FolderInUse, match="in use by the run of process"):
            with lock_folder(tmp_path, "shard-0-of-2"):
                pass
