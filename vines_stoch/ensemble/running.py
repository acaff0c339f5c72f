"""``run``, ``sample`` and ``solve``: a scenario's ensemble planned, run chunk by chunk on the
embedded scheduler or a cluster, folded and consolidated; every realisation in memory; one
realisation's time histories."""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping
from contextlib import ExitStack, closing
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from .. import history as hist
from .. import notices, psd, rare, schedulers, sensitivity, store
from ..binding import binding
from ..environment import memory_problem, require_cluster
from ..kernels import DEFAULT_SIGNALS, check_executor, general_run, keeps_general
from ..metrics import residual_warnings
from ..progress import Progress
from ..results import Results, Solution, as_study, check_whole
from ..scenario import History, Study
from ..scenario.fields import MAX_REALIZATIONS
from ..scene import Scene, build_scene
from ..signals import signal_names
from ..store import (
    CHECKPOINT,
    KEY,
    STUDIES,
    Saved,
    component,
    lock_folder,
    part_path,
    prepare_folder,
    provenance,
    run_key,
)
from .chunks import draw_parameters, recording, run_chunk, run_chunk_cuda, run_viewed, view_of
from .control import Interrupted, client, noting_interrupts
from .folding import Checkpoint, PointState
from .planning import BACKENDS, on_hand, plan, prepare_loops, specialised_loops
from .tables import chosen_paths, consolidate, label_points


def output_directory(study: Study, directory: str | Path | None = None) -> Path:
    """Where a run writes: ``directory``, else the scenario's ``[output] directory``, else
    ``results/<name>`` (the name as one path component: ``store.component``)."""
    return Path(directory or study.base.output.directory or Path("results") / component(study.base.name))


def _check_arguments(out: object, workers: object, chunk: object, realizations: object, paths: object,
                     checkpoint_seconds: object, backend: object, shard: object = None,
                     scheduler: object = None, executor: object = "lanes") -> None:
    """Refuse an argument of ``run`` of the wrong type (``TypeError``) or out of its range
    (``ValueError``), naming it, its value and what is allowed."""
    if shard is not None and not (isinstance(shard, (tuple, list)) and len(shard) == 2
                                  and all(isinstance(v, (int, np.integer)) and not isinstance(v, bool)
                                          for v in shard)):
        raise TypeError(f"shard = {shard!r}: give (i, n), two whole numbers with 0 <= i < n (the i-th of n "
                        "shares of the chunks), or None")
    if scheduler is not None and not isinstance(scheduler, (str, os.PathLike)):
        raise TypeError(f"scheduler = {scheduler!r}: give a dask.distributed scheduler's address "
                        "('tcp://host:8786') or the path of its scheduler file, or None")
    if scheduler is not None:
        require_cluster(str(scheduler))
    if out is not None and not isinstance(out, (str, os.PathLike)):
        raise TypeError(f"out = {out!r}: give a folder's path, or None to run in memory")
    check_whole("realizations", realizations, 1, MAX_REALIZATIONS)
    check_whole("workers", workers, 1)
    check_whole("chunk", chunk, 0, MAX_REALIZATIONS)
    if not isinstance(paths, bool):
        raise TypeError(f"paths = {paths!r}: must be True or False")
    if isinstance(checkpoint_seconds, bool) or not isinstance(checkpoint_seconds, (int, float)) \
            or not checkpoint_seconds >= 0:
        raise ValueError(f"checkpoint_seconds = {checkpoint_seconds!r}: must be a number >= 0")
    if backend not in BACKENDS:
        raise ValueError(f"backend {backend!r}: must be one of {', '.join(BACKENDS)}")
    check_executor(executor)
    if backend == "cuda" and executor != "lanes":
        raise ValueError(f"executor = {executor!r}: chooses how the CPU runs realisations; the cuda backend "
                         "runs one a GPU thread (leave executor at 'lanes')")


def run(scenario: Study | Mapping[str, Any] | str | os.PathLike, out: str | Path | None = None, *,
        workers: int | None = None, chunk: int | None = None, realizations: int | None = None,
        paths: bool = False, resume: bool = False, scheduler: str | None = None, progress: bool = False,
        checkpoint_seconds: float = 30.0, shard: tuple[int, int] | None = None,
        backend: str = "cpu", overwrite: bool = False, executor: str = "lanes") -> Results | None:
    """Run a scenario (a file's path, a dict of its tables or a validated ``Study``) and return
    its ``Results`` (realisations, summary, history statistics where ``[simulation.history]``
    asks for them, and with ``paths`` every realisation's time histories).

    ``out``: the folder that receives ``realizations.parquet``, ``summary.parquet`` (and
    ``history.parquet``); None runs in memory and writes nothing.  ``realizations`` (1 to
    10,000,000): the ensemble size in place of the file's ``[ensemble] realizations``.
    ``paths``: keep the time histories of every realisation (``Results.paths``, on the history
    grid: ``[simulation.history] points``, 1000 by default; never written to the folder).

    ``workers``: threads of the embedded scheduler (default: all cores).  ``scheduler``: the
    address of a running ``dask.distributed`` scheduler to use instead, or the path of its
    scheduler file.  ``resume``: keep what
    a previous, interrupted run of the same scenario finished; ``overwrite``: discard them (a
    new run into a folder that holds an unfinished run's work refuses, ``store.UnfinishedRun``,
    unless it resumes or overwrites).  ``checkpoint_seconds``: how
    often the history statistics are saved for a resume.  ``shard = (i, n)``: run only the
    chunks whose index in the plan is ``i`` modulo ``n`` into the folder, write no results and
    return None (for job arrays: shards run side by side, then a ``resume`` run writes the
    results from their parts; not with history statistics, which need the paths).  ``progress``:
    a line for each step loop compiled, a bar (or lines, in a log) of the realisations done with
    their rate, and the total time, on standard error.

    ``backend``: ``"cpu"`` (numba loops on CPU threads) or ``"cuda"`` (the same loops on an
    NVIDIA GPU, one realisation a thread: ``gpu.py``; its realisations draw from Philox streams,
    not the CPU's, so the two backends give two independent samples of the same law; where no
    GPU is, ``gpu.GPUUnavailable`` says why).  ``executor`` (the CPU's, ``kernels.EXECUTORS``):
    ``"lanes"`` runs the scenes whose scheme allows it in SIMD lanes on Philox streams, the others
    in the scalar loop; ``"scalar"`` runs every scene in the scalar loop on the PCG64 streams of
    ``streams.streams`` (slower: the loop before SIMD lanes, kept as the benchmark's reference).
    The two draw from different streams, so they give two independent samples of the same law;
    within one, the numbers depend on nothing else.

    The directory is owned by one run at a time (``store.lock_folder``): a run into a folder
    another live run writes is refused with ``store.FolderInUse``.  Every file the run writes
    carries its run key (``store.prepare_folder``): a new run deletes what earlier runs left and
    refuses (``store.ForeignFiles``) a folder holding files this program did not write; a resumed
    run refuses parts, results or a checkpoint of another run.  Ctrl-C raises ``Interrupted``
    (a ``KeyboardInterrupt``) saying how many chunks are kept.
    """
    _check_arguments(out, workers, chunk, realizations, paths, checkpoint_seconds, backend, shard, scheduler,
                     executor)
    scheduler = None if scheduler is None else os.fspath(scheduler)
    study = as_study(scenario)
    if backend == "cuda":
        from .. import gpu

        gpu.require()
    if out is None and (resume or shard is not None):
        raise ValueError(f"{'resume' if resume else 'shard'}: needs a folder (out) to keep the chunks in")
    if paths and (resume or shard is not None):
        raise ValueError("paths: not with resume or shard (the chunks kept in the folder keep no paths)")
    if paths:
        _check_paths_memory(study, realizations)
    if shard is not None:
        if not 0 <= shard[0] < shard[1]:
            raise ValueError(f"--shard {shard[0]}/{shard[1]}: give I/N with 0 <= I < N "
                             "(e.g. --shard 0/4)")
        if study.base.simulation.history or study.base.output.spectra:
            raise ValueError(f"--shard: {study.source} asks for history statistics or spectra, which are "
                             "folded from the paths of every realisation in order and cannot be split into "
                             "shards; run it in one job")
    if not isinstance(overwrite, bool):
        raise TypeError(f"overwrite = {overwrite!r}: must be True or False")
    if overwrite and resume:
        raise ValueError("resume and overwrite: give one (resume keeps an unfinished run's work, overwrite "
                         "discards it)")
    options = _Options(workers, chunk, realizations, paths, resume, scheduler, progress, checkpoint_seconds,
                       shard, backend, overwrite, executor)
    notices.emit(study.warnings)  # (the lines the command line prints, as warnings of their categories)
    results = _run_into(study, out, options)
    if results is not None:
        notices.emit(residual_warnings(results.realizations, study.source,
                                       study.base.simulation.residual_tolerance))
    return results


def _run_into(study: Study, out: str | Path | None, options: _Options) -> Results | None:
    """``_run`` in memory, or into the folder ``out`` (made where missing, locked for the run)."""
    if out is None:
        return _run(study, None, options)
    directory = Path(out)
    try:
        directory.mkdir(parents=True, exist_ok=True)
    except FileExistsError:
        raise NotADirectoryError(f"{directory}: exists and is not a folder") from None
    shard = options.shard
    with lock_folder(directory, None if shard is None else f"shard-{shard[0]}-of-{shard[1]}"):
        return _run(study, directory, options)


def _check_paths_memory(study: Study, realizations: int | None) -> None:
    """Refuse ``paths=True`` where every realisation's time histories (sweep points x realisations x
    signals x history points, float64) cannot fit the machine's memory, with the figure."""
    spec = study.base.simulation.history or History()
    count = (realizations or study.base.ensemble.realizations) if study.base.is_random else 1
    need = 8.0 * len(study.points) * count * spec.points * len(spec.signals)
    why = memory_problem(f"paths=True ({len(study.points)} sweep point(s) x {count} realisation(s) x "
                         f"{len(spec.signals)} signal(s) x {spec.points} points)", need)
    if why:
        raise ValueError(f"paths: {why}; ask for fewer realisations or history points ([simulation.history] "
                         "points), or keep chosen realisations' paths ([output] paths)")


@dataclass(frozen=True)
class _Options:
    """The options of ``run`` that ``_run`` takes on."""

    workers: int | None
    chunk: int | None
    realizations: int | None
    paths: bool
    resume: bool
    scheduler: str | None
    progress: bool
    checkpoint_seconds: float
    shard: tuple[int, int] | None
    backend: str
    overwrite: bool = False
    executor: str = "lanes"


def _run(study: Study, directory: Path | None, o: _Options) -> Results | None:
    """``run`` in a directory it owns, or in memory (``directory`` None)."""
    base = study.base
    spec, spectra = base.simulation.history, base.output.spectra
    tracked = bool(spec or spectra)  # (folded from every realisation's paths, in order)
    grid_spec = spec or (History() if o.paths else None)  # (the grid of the paths kept)
    the_plan = plan(study, o.chunk, o.realizations, o.backend, grid_spec, o.executor)
    seed, target = base.ensemble.seed, base.ensemble.target_sem
    signals = tuple(grid_spec.signals) if grid_spec else DEFAULT_SIGNALS
    grids = [hist.grid(scene.n_steps, grid_spec.points) if grid_spec else None for scene in the_plan.scenes]
    recorded = [recording(scene, grid_spec, spectra) for scene in the_plan.scenes]
    views = [view_of(scene, grid_spec, spectra) for scene in the_plan.scenes]
    # (the scalar executor's numbers are other streams': a run key of its own)
    key = run_key(study.text, the_plan.chunks, o.backend if o.executor == "lanes" else f"{o.backend}, scalar")
    keep = "--resume" if o.resume else "--shard" if o.shard is not None else None
    found = set() if directory is None else prepare_folder(directory, key, len(the_plan.chunks), study.source,
                                                           keep, o.overwrite)
    checkpoint = None if directory is None else Checkpoint(directory / "parts" / CHECKPOINT, key,
                                                            o.checkpoint_seconds)
    states = [PointState([c for c in the_plan.chunks if c[0] == p], tree=hist.Tree() if spec else None,
                         spectrum=psd.Spectrum() if spectra else None)
              for p in range(len(the_plan.scenes))]
    if o.resume and tracked:
        checkpoint.load(states)
    folded_chunks = {c for s in states for c in s.chunks[:s.folded]}
    # a part on disk is reused unless its history paths are still needed
    on_disk = {c for c in the_plan.chunks if directory is not None and part_path(directory, *c) in found}
    reusable = folded_chunks if tracked else on_disk
    ready: dict[tuple[int, int, int], tuple[pd.DataFrame, np.ndarray | None, np.ndarray | None]] = {}
    frames: dict[tuple[int, int, int], pd.DataFrame] = {}  # (the tables of the chunks this run runs)
    kept_paths: dict[tuple[int, int, int], np.ndarray] = {}

    def fold_ready() -> None:
        for state in states:
            while not state.done:
                c = state.chunks[state.folded]
                if c in ready:
                    frame, chunk_paths, estimates = ready.pop(c)
                elif c in reusable and not tracked:
                    frame = pd.read_parquet(part_path(directory, *c)) if target else None
                    chunk_paths = estimates = None
                else:
                    break
                state.fold(frame, chunk_paths, target, estimates)

    mine = the_plan.chunks if o.shard is None else the_plan.chunks[o.shard[0]::o.shard[1]]
    todo = [c for c in mine if c not in reusable]
    total = sum(c[2] - c[1] for c in mine)
    done = total - sum(c[2] - c[1] for c in todo)
    if o.backend == "cpu" and not o.scheduler and todo:  # (loops compiled already: loaded, not run)
        the_plan = on_hand(the_plan, seed, base.ensemble.common_random_numbers, recorded[0][1],
                           recorded[0][0] or DEFAULT_SIGNALS, o.executor, o.progress)
    chunk_runner = (run_chunk_cuda if o.backend == "cuda"
                    else partial(run_chunk, executor=o.executor, general=the_plan.general))

    def call(c: tuple[int, int, int]) -> tuple:
        signals_c, grid_c = recorded[c[0]]
        return run_viewed, (chunk_runner, views[c[0]], the_plan.scenes[c[0]], seed, *c, grid_c,
                        study if base.uncertain else None, base.ensemble.common_random_numbers,
                        signals_c or DEFAULT_SIGNALS)

    def skip(c: tuple[int, int, int]) -> bool:
        return states[c[0]].done

    def kept() -> int:
        """Chunks of this run that a resumed run does not run again."""
        def held(c: tuple[int, int, int]) -> bool:
            return c in checkpoint.folded if tracked else part_path(directory, *c).exists()

        return sum(held(c) or (states[c[0]].stop is not None and c[1] >= states[c[0]].stop) for c in mine)

    try:
        if o.backend == "cpu" and not o.scheduler and todo:
            prepare_loops(the_plan.scenes, seed, base.ensemble.common_random_numbers, recorded[0][1],
                          recorded[0][0] or DEFAULT_SIGNALS, show=o.progress, executor=o.executor,
                          general=the_plan.general, batch=the_plan.batch)
        with ExitStack() as stack:
            interrupted = stack.enter_context(noting_interrupts())
            fold_ready()
            bar = stack.enter_context(Progress(total, done, enabled=o.progress))
            if o.scheduler:
                dask_client = stack.enter_context(client(o.scheduler, o.progress))
                where = f"dask.distributed at {dask_client.scheduler.address}"
                results = schedulers.distributed(dask_client, todo, call, skip)
            else:  # (one GPU: its chunks one after the other)
                threads = 1 if o.backend == "cuda" else o.workers or os.cpu_count() or 1
                where, results = "embedded", schedulers.embedded(todo, call, skip, threads)
            stack.enter_context(closing(results))  # (its threads or futures stop before the client goes)
            if o.backend == "cuda":  # (the workers' GPUs of a cluster are theirs to name)
                from .. import gpu

                where = f"{where}, cuda" + ("" if o.scheduler else f" ({gpu.device_name()})")
            folding = False
            try:
                for c, (frame, chunk_paths, estimates) in results:
                    label_points(frame, study, c[0])
                    frames[c] = frame  # (the consolidation's rows: its part is not read back)
                    if directory is not None:
                        store.write_table(frame, part_path(directory, *c), {KEY: key})
                    if o.paths:
                        kept_paths[c] = chunk_paths
                    ready[c] = (frame, chunk_paths, estimates)
                    folding = True
                    fold_ready()
                    folding = False
                    for rc in [rc for rc in ready if states[rc[0]].done]:
                        ready.pop(rc)
                    if tracked and checkpoint is not None:
                        checkpoint.save(states)
                    bar.advance(c[2] - c[1])
                    if interrupted.is_set():
                        raise KeyboardInterrupt
            except BaseException:
                if tracked and checkpoint is not None and not folding:  # keep what was folded, unless
                    checkpoint.save(states, force=True)  # interrupted mid-fold
                raise
            if interrupted.is_set():
                raise KeyboardInterrupt
        if o.shard is not None:
            return None
        where += ", scalar loop" if o.executor == "scalar" else ""
        meta = provenance(study.text, study.source, seed, where, o.backend, key)
        chosen = chosen_paths(study, the_plan, states, chunk_runner) if base.output.paths else None
        studies = {}
        saved = Saved(None if directory is None else directory / "parts" / STUDIES, key, o.resume)
        if base.rare is not None:
            studies["rare"] = rare.table(study, _scene_of(study), o.progress,
                                         lambda point, values: binding(study, point).scene(values), saved,
                                         o.backend)
        if base.sensitivity is not None:
            studies["sensitivity"] = sensitivity.table(study, _design_output(study, chunk_runner), o.progress,
                                                       saved)
        return consolidate(study, the_plan, states, directory, frames, meta, grids, spec,
                            kept_paths if o.paths else None, signals, views, chosen, studies)
    except KeyboardInterrupt as exc:
        if directory is None:
            raise
        raise Interrupted(kept(), len(mine)) from exc


def _scene_of(study: Study) -> Callable[[int, int], Scene]:
    """The scene of path ``j`` of sweep point ``point`` for a rare-event estimate: the point's,
    or with uncertain parameters those realisation ``j`` of the ensemble draws."""
    base = study.base
    scenes = [build_scene(scenario) for scenario in study.points]
    if not base.uncertain:
        return lambda point, j: scenes[point]
    bound = [binding(study, p) for p in range(len(study.points))]
    return lambda point, j: bound[point].scene(draw_parameters(study, base.ensemble.seed, point, j,
                                                               base.ensemble.common_random_numbers))


def _design_output(study: Study, runner: Callable = run_chunk) -> Callable[[int, dict[str, float]], float]:
    """A Sobol design point's output (``sensitivity.table``): the mean of ``[sensitivity]
    metric`` over realisations ``0 .. R - 1`` of the point's scene with the parameters ``values``
    (the same noise at every design point), or for ``p_NAME`` the fraction that exceeded limit
    NAME; realisations that failed are left out.  ``runner``: the chunk runner of the run's
    backend (``run_chunk``, or ``run_chunk_cuda``: the realisations on the GPU)."""
    base = study.base
    spec = base.sensitivity
    bound: dict[int, Any] = {}

    def output(point: int, values: dict[str, float]) -> float:
        if point not in bound:
            bound[point] = binding(study, point)
        scene = bound[point].scene(values)
        frame, _ = runner(scene, base.ensemble.seed, point, 0, spec.realizations,
                          common=base.ensemble.common_random_numbers)
        ok = frame[frame["status"] == "ok"]
        if spec.metric.startswith("p_") and f"first_passage_{spec.metric[2:]}" in ok.columns:
            return float(ok[f"first_passage_{spec.metric[2:]}"].notna().mean())
        return float(ok[spec.metric].mean())

    return output


def sample(study: Study, workers: int | None = None, executor: str = "lanes") -> pd.DataFrame:
    """Every realisation of every sweep point, in memory (no files, no history, no early
    stopping): the metric rows in point and realisation order, the numbers ``run`` gives with the
    same ``executor`` (``kernels.EXECUTORS``)."""
    check_executor(executor)
    the_plan = plan(study, executor=executor)
    base = study.base
    the_plan = on_hand(the_plan, base.ensemble.seed, base.ensemble.common_random_numbers, executor=executor,
                       show=False)
    uncertain = study if base.uncertain else None
    runner = partial(run_chunk, executor=executor, general=the_plan.general)

    def call(c: tuple[int, int, int]) -> tuple:
        return runner, (the_plan.scenes[c[0]], base.ensemble.seed, *c, None, uncertain,
                        base.ensemble.common_random_numbers)

    done = dict(schedulers.embedded(the_plan.chunks, call, lambda c: False, workers or os.cpu_count() or 1))
    return pd.concat([label_points(done[c][0], study, c[0]) for c in the_plan.chunks], ignore_index=True)


def solve(scenario: Study | Mapping[str, Any] | str | os.PathLike, *, point: int = 0, realization: int = 0,
          points: int | None = None, signals: list[str] | tuple[str, ...] | None = None,
          executor: str = "lanes") -> Solution:
    """One realisation of a scenario with its time histories (``Solution``: ``ts``, ``ys`` by
    signal name, and its metrics, the same values as realisation ``realization`` of sweep point
    ``point`` in an ensemble run with the same ``executor``, ``kernels.EXECUTORS``).  ``points``:
    rows of the time grid (default: every step); ``signals``: any of ``signals.signal_names``
    (default ``x1``, ``e1``)."""
    check_executor(executor)
    study = as_study(scenario)
    check_whole("point", point, 0, len(study.points) - 1, allow_none=False)
    check_whole("realization", realization, 0, 2**63 - 1, allow_none=False)
    check_whole("points", points, 2, 100_000_000)
    scene = build_scene(study.points[point])
    signals = tuple(signals or DEFAULT_SIGNALS)
    allowed = signal_names(scene.n_floors, scene.kind.shape[0])
    for name in signals:
        if name not in allowed:
            raise ValueError(f"signals: {name!r} is not a signal of this scenario "
                             f"(allowed: {', '.join(allowed)})")
    grid = hist.grid(scene.n_steps, points or scene.n_steps + 1)
    base = study.base
    seed, common = base.ensemble.seed, base.ensemble.common_random_numbers
    general = keeps_general(general_run(scene.n_steps), lambda: specialised_loops(
        [scene], seed, common, grid, signals, executor, 1, False))
    frame, paths = run_chunk(scene, seed, point, realization, realization + 1, grid,
                             study if base.uncertain else None, common, signals, executor, general)
    label_points(frame, study, point)
    ys = {s: paths[i, :, 0] for i, s in enumerate(signals)}
    return Solution(scene.dt * grid[0] * np.arange(grid[1]), ys, frame.iloc[0], point, realization, study)
