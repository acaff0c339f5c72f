"""Output folders: nothing found in one is executed, another run's parts or results are never
taken, files the program did not write are never deleted, and Ctrl-C says what it kept (each
case with two processes or a planted file)."""

from __future__ import annotations

import os
import pickle
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from tests.helpers import ROOT, cli, study_from, toml_text, two_dof_data
from vines_stoch import history, load_scenario, run, store
from vines_stoch.store import KEY, ForeignFiles, png_text, read_arrays, read_metadata, write_arrays


def noisy(intensity: float, realizations: int = 200, history: bool = False, seed: int = 0) -> dict:
    """A primary with a cubic NES under white noise, one realisation a chunk: 10^5 steps each (a
    few hundred chunks a second), or with ``history`` 500 steps and the history statistics."""
    simulation = {"duration": 100.0, "dt": 0.001}
    if history:
        simulation = {"duration": 5.0, "dt": 0.01, "history": {"points": 21, "quantiles": [0.05, 0.95]}}
    return {"name": "folders", **two_dof_data(), "loads": [{"type": "white-noise", "intensity": intensity}],
            "simulation": simulation, "ensemble": {"realizations": realizations, "chunk": 1, "seed": seed}}


def fragile(seed: int) -> dict:
    """A linear primary under white noise swept over intensity, with a limit to fit."""
    return {"name": "fragile", "primary": {"mass": 1.0, "stiffness": 39.5, "damping": 0.63},
            "loads": [{"type": "white-noise", "intensity": 1.0}],
            "simulation": {"duration": 2.0, "dt": 0.01}, "ensemble": {"realizations": 40, "seed": seed},
            "sweep": {"loads.0.intensity": [0.2, 0.6, 2.0]},
            "limits": {"roof": {"metric": "x1_max", "value": 0.25}}}


def write(tmp_path: Path, name: str, data: dict) -> Path:
    path = tmp_path / f"{name}.toml"
    path.write_text(toml_text(data))
    return path


def start(scenario: Path, out: Path, *extra: str) -> subprocess.Popen:
    """``vines-stoch run SCENARIO --out OUT`` as a process of its own, taking Ctrl-C (SIGINT) as
    a user's terminal does whatever this process does with it (a shell's background job, for one,
    ignores it, and a child inherits that)."""
    return subprocess.Popen([sys.executable, "-m", "vines_stoch.cli", "run", str(scenario), "--out", str(out),
                             "--quiet", "--workers", "1", *extra], cwd=ROOT, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))


def parts_of(out: Path) -> list[Path]:
    return sorted((out / "parts").glob("point*.parquet"))


def wait_for_parts(out: Path, count: int, process: subprocess.Popen) -> None:
    deadline = time.monotonic() + 300
    while len(parts_of(out)) < count:
        assert process.poll() is None, process.communicate()
        assert time.monotonic() < deadline
        time.sleep(0.02)


def killed(scenario: Path, out: Path, count: int = 3) -> None:
    """Start a run of ``scenario`` into ``out`` and kill it (SIGKILL) once it has written ``count``
    parts (the manifest names it once the parts of earlier runs are gone)."""
    victim = start(scenario, out)
    manifest = out / "parts" / "manifest.json"
    deadline = time.monotonic() + 300
    while not (manifest.exists() and str(scenario) in manifest.read_text()):
        assert victim.poll() is None, victim.communicate()
        assert time.monotonic() < deadline
        time.sleep(0.02)
    wait_for_parts(out, count, victim)
    victim.send_signal(signal.SIGKILL)
    victim.wait(timeout=60)
    assert victim.returncode == -signal.SIGKILL


class Planted:
    """A pickle whose loading runs code: it creates the file ``path`` (``open(path, "w")``)."""

    def __init__(self, path: Path):
        self.path = path

    def __reduce__(self):
        return open, (str(self.path), "w")


def test_planted_pickles_and_other_runs_checkpoints_are_never_loaded(tmp_path):
    """The history statistics' checkpoint is data (npz without pickles, with the run key and a
    checksum): a planted ``history.pickle`` is never read, a planted ``history.npz`` holding a
    pickle is refused unread, another run's checkpoint is refused; a resume from the run's own
    checkpoint gives byte for byte the results it gave."""
    a, b = tmp_path / "a", tmp_path / "b"
    scenario = write(tmp_path, "a", noisy(0.1, 30, history=True))
    run(load_scenario(scenario), a, workers=1, checkpoint_seconds=0.0)  # (a checkpoint after every chunk)
    run(study_from(noisy(0.1, 30, history=True, seed=1)), b, workers=1, checkpoint_seconds=0.0)
    first = {name: (a / name).read_bytes() for name in ("realizations.parquet", "history.parquet")}
    own = (a / "parts" / "history.npz").read_bytes()
    marker = tmp_path / "executed"
    resume = ("run", scenario, "--out", a, "--quiet", "--workers", "1", "--resume")

    shutil.copy(b / "parts" / "history.npz", a / "parts" / "history.npz")
    code, err = cli(*resume)
    assert code == 2 and "history statistics of another run" in err and str(a) in err, err

    with (a / "parts" / "history.npz").open("wb") as stream:
        np.savez(stream, header=np.array([Planted(marker)], dtype=object))
    code, err = cli(*resume)
    assert code == 2 and "not a checkpoint vines-stoch wrote" in err, err
    assert not marker.exists()

    (a / "parts" / "history.npz").write_bytes(own)
    (a / "parts" / "history.pickle").write_bytes(pickle.dumps(Planted(marker)))
    code, err = cli(*resume)
    assert code == 0, err
    assert not marker.exists()
    for name, content in first.items():
        assert (a / name).read_bytes() == content

    code, err = cli(*resume[:-1])  # a new run: it does not delete what it did not write
    assert code == 2 and "parts/history.pickle" in err and "did not write" in err, err
    assert not marker.exists() and (a / "parts" / "history.pickle").exists()


def test_resume_never_takes_another_run_s_parts_manifest_or_not(tmp_path):
    """Scenario A is killed midway and its parts lose their manifest: --resume of scenario B is
    refused (each part names its run) and touches nothing; a part of A planted among B's own
    (B's manifest in place) is refused too."""
    a_file, b_file = write(tmp_path, "a", noisy(0.1)), write(tmp_path, "b", noisy(0.2, 20))
    out = tmp_path / "out"
    killed(a_file, out)
    (out / "parts" / "manifest.json").unlink()
    before = {p.name: p.stat().st_mtime_ns for p in parts_of(out)}
    code, err = cli("run", b_file, "--out", out, "--quiet", "--workers", "1", "--resume")
    assert code == 2 and f"{out}: --resume:" in err and "belong to another run" in err, err
    assert "run without --resume" in err and "another --out folder" in err
    assert {p.name: p.stat().st_mtime_ns for p in parts_of(out)} == before
    assert not (out / "realizations.parquet").exists()

    b = tmp_path / "b"
    assert cli("run", b_file, "--out", b, "--quiet", "--workers", "1")[0] == 0
    planted = parts_of(out)[1]  # (the chunk plans agree on the first 20 names)
    shutil.copy(planted, b / "parts" / planted.name)
    code, err = cli("run", b_file, "--out", b, "--quiet", "--workers", "1", "--resume")
    assert code == 2 and f"parts/{planted.name}" in err, err


def test_a_run_killed_in_an_earlier_run_s_folder_leaves_nothing_to_report(tmp_path):
    """A finished run of A, then a run of B into the same folder is killed: B removed A's
    results when it started, so ``report`` says the folder holds B's unfinished run; A's results
    planted back beside B's parts are refused (they and the parts belong to two runs)."""
    a_file, b_file = write(tmp_path, "a", noisy(0.1, 20)), write(tmp_path, "b", noisy(0.2))
    out, aside = tmp_path / "out", tmp_path / "aside"
    assert cli("run", a_file, "--out", out, "--quiet", "--workers", "1")[0] == 0
    shutil.copytree(out, aside)
    killed(b_file, out)
    assert not (out / "realizations.parquet").exists() and not (out / "summary.parquet").exists()
    code, err = cli("report", out, "--out", tmp_path / "reports")
    assert code == 2 and "no summary.parquet" in err and "unfinished run" in err and "--resume" in err, err
    for name in ("realizations.parquet", "summary.parquet"):
        shutil.copy(aside / name, out / name)
    code, err = cli("report", out, "--out", tmp_path / "reports")
    assert code == 2 and "belong to two runs" in err and str(out) in err, err
    assert not (tmp_path / "reports").exists()


def test_an_earlier_run_s_fragility_is_never_reported_with_a_new_run(tmp_path):
    """A run with a fragility fit, then a run of another scenario into the same folder: the new
    run deletes the fit and its plot (this program's, known by their run key); the earlier fit
    planted back is refused by ``report`` and ``fragility``."""
    a_file, b_file = write(tmp_path, "a", fragile(1)), write(tmp_path, "b", fragile(2))
    out = tmp_path / "out"
    fit = ("fragility", out, "--limit", "roof", "--im", "loads.0.intensity", "--samples", "50")
    assert cli("run", a_file, "--out", out, "--quiet")[0] == 0
    code, err = cli(*fit)
    assert code == 0, err
    old = (out / "fragility.parquet").read_bytes()
    assert read_metadata(out / "fragility.parquet")[KEY] == read_metadata(out / "summary.parquet")[KEY]
    if (out / "fragility_roof.png").exists():  # (where matplotlib is installed)
        assert png_text(out / "fragility_roof.png")[KEY] == read_metadata(out / "summary.parquet")[KEY]
    assert cli("run", b_file, "--out", out, "--quiet")[0] == 0
    assert not (out / "fragility.parquet").exists() and not (out / "fragility_roof.png").exists()
    code, err = cli("report", out, "--out", tmp_path / "reports")
    assert code == 0, err
    assert "## Fragility" not in (tmp_path / "reports" / "fragile" / "report.md").read_text()
    (out / "fragility.parquet").write_bytes(old)
    for command in (("report", out, "--out", tmp_path / "again"), fit):
        code, err = cli(*command)
        assert code == 2 and f"{out / 'fragility.parquet'}: belongs to another run" in err, err
    assert (out / "fragility.parquet").read_bytes() == old


def test_files_the_program_did_not_write_are_never_deleted(tmp_path):
    """Planted files of the user's own in ``parts/`` (a note, a Parquet file) and in place of a
    result file: a new run refuses, naming them, and deletes nothing; a resume, which deletes
    nothing, goes on beside them."""
    scenario = write(tmp_path, "a", noisy(0.1, 10))
    out = tmp_path / "out"
    assert cli("run", scenario, "--out", out, "--quiet", "--workers", "1")[0] == 0
    note, table = out / "parts" / "notes.txt", out / "parts" / "mine.parquet"
    note.write_text("my notes")
    pd.DataFrame({"x": [1.0]}).to_parquet(table)
    parts = {p.name: p.read_bytes() for p in parts_of(out)}
    code, err = cli("run", scenario, "--out", out, "--quiet", "--workers", "1")
    assert code == 2 and "parts/mine.parquet, parts/notes.txt" in err and "did not write" in err, err
    assert note.read_text() == "my notes" and table.exists()
    assert {p.name: p.read_bytes() for p in parts_of(out)} == parts
    assert cli("run", scenario, "--out", out, "--quiet", "--workers", "1", "--resume")[0] == 0
    assert note.read_text() == "my notes"
    note.unlink()
    table.unlink()
    pd.DataFrame({"x": [1.0]}).to_parquet(out / "summary.parquet")
    code, err = cli("run", scenario, "--out", out, "--quiet", "--workers", "1")
    assert code == 2 and "(summary.parquet)" in err, err
    assert pd.read_parquet(out / "summary.parquet").columns.tolist() == ["x"]


def test_ctrl_c_exits_130_and_says_how_many_chunks_are_kept(tmp_path):
    """SIGINT to a real run: exit status 130, "interrupted: N of M chunks kept; finish with
    --resume" with N the parts on disk; the resume keeps them."""
    count = 200
    scenario = write(tmp_path, "a", noisy(0.1, count))
    out = tmp_path / "out"
    process = start(scenario, out)
    wait_for_parts(out, 3, process)
    process.send_signal(signal.SIGINT)
    _, err = process.communicate(timeout=120)
    kept = parts_of(out)
    assert process.returncode == 130, err
    assert f"interrupted: {len(kept)} of {count} chunks kept; finish with --resume" in err, err
    assert 3 <= len(kept) < count
    stamps = {p: p.stat().st_mtime_ns for p in kept}
    assert cli("run", scenario, "--out", out, "--quiet", "--workers", "1", "--resume")[0] == 0
    assert {p: p.stat().st_mtime_ns for p in kept} == stamps
    assert len(pd.read_parquet(out / "realizations.parquet")) == count


def test_a_ctrl_c_lost_on_its_way_still_stops_the_run(tmp_path, monkeypatch):
    """A KeyboardInterrupt dropped where Ctrl-C landed (a finaliser, a library's broad handler:
    here one around the writing of the third part) still ends the run after that chunk: exit
    status 130 and what is kept."""
    scenario = write(tmp_path, "a", noisy(0.1, 20))
    out = tmp_path / "out"
    real_write = store.write_table
    written = []

    def write_and_drop_a_ctrl_c(frame, path, meta=None):
        real_write(frame, path, meta)
        written.append(path)
        if len(written) == 3:
            try:
                os.kill(os.getpid(), signal.SIGINT)
                time.sleep(5)  # (the signal's KeyboardInterrupt is raised here...)
            except KeyboardInterrupt:
                pass  # (... and dropped)

    monkeypatch.setattr(store, "write_table", write_and_drop_a_ctrl_c)
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)  # (as in a command's process)
    try:
        code, err = cli("run", scenario, "--out", out, "--quiet", "--workers", "1")
    finally:
        signal.signal(signal.SIGINT, previous)
    assert code == 130 and "interrupted: 3 of 20 chunks kept; finish with --resume" in err, err
    assert len(parts_of(out)) == 3 and not (out / "realizations.parquet").exists()


def test_a_checkpoint_is_data_with_its_key_and_checksum(tmp_path, monkeypatch):
    """History statistics (a tree with finished levels and an open leaf) go through a checkpoint
    file and back exactly; arrays changed under their header's checksum are refused."""
    monkeypatch.setattr(history, "BLOCK", 4)
    rng = np.random.default_rng(5)
    tree = history.Tree()
    tree.add(rng.normal(size=(2, 7, 11)), rng.random(11) > 0.2)
    assert tree.levels and tree.pending
    path = tmp_path / "history.npz"
    write_arrays(path, tree.to_arrays(), "abc")
    key, arrays = read_arrays(path)
    again = history.Tree.from_arrays(arrays)
    assert key == "abc" and again.seen == tree.seen
    want, got = tree.result(), again.result()
    for name in ("count", "weight", "rank_error"):
        assert getattr(got, name) == getattr(want, name)
    for name in ("mean", "m2", "values"):
        np.testing.assert_array_equal(getattr(got, name), getattr(want, name))
    with np.load(path) as npz:
        stored = {name: npz[name] for name in npz.files}
    stored["seen"] = np.array(tree.seen + 1)
    with path.open("wb") as stream:
        np.savez(stream, **stored)
    with pytest.raises(ForeignFiles, match="damaged"):
        read_arrays(path)


def test_a_new_run_refuses_to_discard_an_unfinished_runs_work(tmp_path, monkeypatch):
    """A run interrupted after some chunks: running again into its folder without ``--resume``
    refuses (the command line with exit 2 and both ways out named; Python with
    ``UnfinishedRun``) and leaves the kept parts in place; ``--overwrite`` discards them and runs
    afresh; a finished run's folder is replaced without a word, as before."""
    from tests.helpers import run_interrupted
    from vines_stoch.store import UnfinishedRun

    data = noisy(0.05, realizations=20)
    out = tmp_path / "out"
    run_interrupted(monkeypatch, data, out, after=5)
    kept = parts_of(out)
    assert kept and not (out / "summary.parquet").exists()
    with pytest.raises(UnfinishedRun, match="--resume .* or with --overwrite"):
        run(data, out)
    assert parts_of(out) == kept
    path = write(tmp_path, "noisy", data)
    code, err = cli("run", path, "--out", out, "--quiet")
    assert code == 2 and "unfinished run" in err and "--overwrite" in err and parts_of(out) == kept
    with pytest.raises(ValueError, match="resume and overwrite: give one"):
        run(data, out, resume=True, overwrite=True)
    fresh = run(data, out, overwrite=True)
    assert len(fresh.realizations) == 20 and (out / "summary.parquet").exists()
    assert len(run(data, out).realizations) == 20  # (a finished run's folder: replaced)


@pytest.mark.parametrize("name", ["../../escaped", "/tmp/absolute-escape", "a/../../b", ".."])
def test_names_never_lead_outside_the_folder(tmp_path, name):
    """A scenario ``name`` with ``..`` or an absolute path: the default results folder and the
    report's folder are one path component inside the folders named (``results/``, ``--out``)."""
    from vines_stoch.ensemble import output_directory
    from vines_stoch.reports import report
    from vines_stoch.store import component

    data = {**fragile(1), "name": name}
    assert output_directory(study_from(data)).parent == Path("results")
    assert "/" not in component(name) and component(name) not in ("", ".", "..")
    run(data, tmp_path / "run")
    out = tmp_path / "reports"
    path = report([tmp_path / "run"], out)
    assert path.parent.parent == out and path.parent.name == component(name)
    assert sorted(p for p in tmp_path.rglob("*") if p.is_file() and tmp_path / "run" not in p.parents
                  ) == sorted(p for p in out.rglob("*") if p.is_file())


def test_a_nul_in_the_name_is_refused(tmp_path):
    from vines_stoch.scenario import ScenarioError

    with pytest.raises(ScenarioError, match="name = .*must hold no control characters"):
        study_from({**fragile(1), "name": "bad\x00name"})


def test_links_planted_in_the_report_folder_are_not_followed(tmp_path):
    """A link planted where the report writes: its folder linked elsewhere is refused; a file
    linked elsewhere is replaced by a file of the report's own, the link's target untouched."""
    from vines_stoch.reports import report
    from vines_stoch.store import OutsideFolder

    run(fragile(1), tmp_path / "run")
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    out = tmp_path / "reports"
    out.mkdir()
    (out / "fragile").symlink_to(elsewhere, target_is_directory=True)
    with pytest.raises(OutsideFolder, match="leads outside"):
        report([tmp_path / "run"], out)
    assert not any(elsewhere.iterdir())
    (out / "fragile").unlink()
    (out / "fragile").mkdir()
    victim = elsewhere / "victim.md"
    victim.write_text("keep me")
    (out / "fragile" / "report.md").symlink_to(victim)
    (out / "fragile" / "edm_vs_input_energy.png").symlink_to(elsewhere / "victim.png")
    path = report([tmp_path / "run"], out)
    assert victim.read_text() == "keep me" and not (elsewhere / "victim.png").exists()
    assert not path.is_symlink() and path.read_text().startswith("# Report")


def test_a_truncated_part_is_called_damaged(tmp_path, monkeypatch):
    """A part of an interrupted run cut short (a Parquet file that cannot be read): ``--resume``
    names it as damaged and says what to do, instead of blaming another run."""
    from tests.helpers import run_interrupted
    from vines_stoch.store import DamagedFile

    data = noisy(0.05, realizations=20)
    out = tmp_path / "out"
    run_interrupted(monkeypatch, data, out, after=5)
    part = parts_of(out)[0]
    part.write_bytes(part.read_bytes()[:len(part.read_bytes()) // 2])
    with pytest.raises(DamagedFile, match=rf"{part.name}: damaged .* delete it and run again with --resume"):
        run(data, out, resume=True)
    part.unlink()
    assert len(run(data, out, resume=True).realizations) == 20
