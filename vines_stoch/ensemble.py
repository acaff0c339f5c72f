"""Monte Carlo ensembles: chunk plan, per-realisation random streams, dask execution,
streamed Parquet parts, resume and convergence stopping.

Realisation ``r`` draws from one stream per purpose (``streams``: step increments, bridge
draws, filter noise, uncertain parameters), each keyed by (seed, purpose, realisation): its
numbers depend on nothing else, so results are bitwise identical for any chunk size, worker
count or scheduler, and with common random numbers the same at every sweep point.  Chunks run on
dask's embedded threaded scheduler or a ``dask.distributed`` cluster; each finished chunk is
written at once as an atomic part file, and the driver folds chunks into the history
statistics and the ``target_sem`` test in realisation order, so neither depends on which chunk
finished first.
"""

from __future__ import annotations

import math
import os
import signal
import sys
import threading
import time
from collections.abc import Iterator
from contextlib import ExitStack, closing, contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from . import history as hist
from . import schedulers
from .binding import binding
from .kernels import needed_streams, sample_buffer, simulate
from .metrics import METRICS, finish_table, ground_intensity, summarise
from .outputs import POINCARE_SAMPLES
from .progress import Progress
from .scenario import History, Study
from .scene import Scene, build_scene
from .store import (
    CHECKPOINT,
    KEY,
    ForeignFiles,
    lock_folder,
    part_path,
    prepare_folder,
    provenance,
    read_arrays,
    read_results,
    run_key,
    write_arrays,
    write_table,
)
from .streams import FILTER, PARAMETERS, generator, streams

#: Target work of one chunk, in path-steps (about 0.1-0.3 s of compute).
CHUNK_STEPS = 5_000_000
#: Automatic chunks split a sweep point's ensemble into at least this many tasks.
CHUNKS_PER_POINT = 32
#: Largest history paths buffer of one chunk, in bytes (caps the chunk size when history
#: statistics are asked for).
HISTORY_CHUNK_BYTES = 8_000_000
#: ``target_sem`` is tested at every multiple of this many realisations (and never before).
TARGET_STEP = 100
#: Realisations of an automatic chunk of the cuda backend (a launch fills a large GPU from
#: about 1e5 threads on; ``gpu.simulate_many`` splits a chunk into launches that fit its memory).
GPU_CHUNK = 1 << 20
#: Largest history paths and Poincare samples of one cuda chunk on the host, in bytes.
GPU_CHUNK_BYTES = 1 << 29
#: Where ensembles run: ``run_chunk`` on CPU threads or ``run_chunk_cuda`` on an NVIDIA GPU.
BACKENDS = ("cpu", "cuda")


def draw_parameters(study: Study, seed: int, point: int, realization: int,
                    common: bool = True) -> dict[str, float]:
    """Values of the uncertain parameters of one realisation, in file order."""
    gen = generator(seed, point, realization, PARAMETERS, common)
    return {key: float(dist.draw(gen)) for key, dist in study.base.uncertain.items()}


def run_chunk(scene: Scene, seed: int, point: int, start: int, stop: int,
              grid: tuple[int, int] | None = None, study: Study | None = None,
              common: bool = True,
              signals: tuple[str, ...] = hist.SIGNALS) -> tuple[pd.DataFrame, np.ndarray | None]:
    """Realisations ``start..stop-1`` of one sweep point: one metric row each and, when a
    history ``grid = (stride, size)`` is asked for, the paths of the history ``signals``
    ``(len(signals), size, stop - start)``.  With ``study`` (a study with uncertain parameters) each
    realisation runs its own scene (``binding``: the point's scene with the drawn values set), its
    drawn values in columns named by their keys.
    ``common``: common random numbers across sweep points (see ``generator``)."""
    raws, scenes, samples_rows, drawn_rows, intensities = [], [], [], [], []
    paths = None if grid is None else np.full((len(signals), grid[1], stop - start), np.nan)
    columns = len(hist.SIGNALS) + (scene.n_floors if hist.needs_floors(signals) else 0)
    path = None if grid is None else np.full((grid[1], columns), np.nan)
    bound = binding(study, point) if study is not None else None
    for r in range(start, stop):
        drawn = draw_parameters(study, seed, point, r, common) if study is not None else {}
        if drawn:
            scene = bound.scene(drawn)
        samples = sample_buffer(scene)
        if path is not None:
            path.fill(np.nan)
        increments, bridge, filters = needed_streams(scene)
        gens = streams(seed, point, r, increments=increments, bridge=bridge, filters=filters, common=common)
        raws.append(simulate(scene, gens, samples=samples, history=path, stride=grid[0] if grid else 1))
        if paths is not None:
            paths[:, :, r - start] = hist.select(path, signals)
        scenes.append(scene)
        samples_rows.append(samples)
        drawn_rows.append(drawn)
        # (the filter stream afresh: the ground path the realisation saw)
        intensities.append(ground_intensity(scene, streams(seed, point, r, increments=False, bridge=False,
                                                           filters=filters, common=common))
                           if scene.im_period > 0 else {})
    return _table(np.stack(raws), scenes if study is not None else scene, samples_rows, point, start,
                  drawn_rows, intensities), paths


def run_chunk_cuda(scene: Scene, seed: int, point: int, start: int, stop: int,
                   grid: tuple[int, int] | None = None, study: Study | None = None,
                   common: bool = True,
                   signals: tuple[str, ...] = hist.SIGNALS) -> tuple[pd.DataFrame, np.ndarray | None]:
    """``run_chunk`` on the GPU (``gpu.simulate_many``): the same table and paths, realisation
    ``r`` drawing from its Philox streams (``kernels/rng.py``) instead of the CPU's PCG64 streams
    (its uncertain parameters still come from the CPU's parameter stream)."""
    from . import gpu
    from .kernels.rng import philox_stream

    n = stop - start
    drawn_rows = [draw_parameters(study, seed, point, r, common) if study is not None else {}
                  for r in range(start, stop)]
    scenes = [binding(study, point).scene(d) for d in drawn_rows] if study is not None else [scene] * n
    columns = len(hist.SIGNALS) + (scene.n_floors if hist.needs_floors(signals) else 0)
    batch = gpu.simulate_many(scenes if study is not None else scene, seed, point, start, stop, common, grid,
                              columns)
    samples = list(batch.samples) if batch.samples.shape[1] else [None] * n
    # (the filter stream afresh: the ground path the realisation saw)
    intensities = [ground_intensity(s, philox_stream(seed, FILTER, r, point, common))
                   if s.im_period > 0 else {} for s, r in zip(scenes, range(start, stop))]
    paths = None if grid is None else hist.select(batch.history.transpose(1, 2, 0), signals)
    return _table(batch.raw, scenes if study is not None else scene, samples, point, start, drawn_rows,
                  intensities), paths


def _table(raw: np.ndarray, scenes: Scene | list[Scene], samples: list, point: int, start: int,
           drawn_rows: list[dict[str, float]], intensities: list[dict[str, float]]) -> pd.DataFrame:
    """A chunk's table: point, realisation, drawn parameters, the metrics (``finish_table``),
    then the intensity measures where the scene asks for them."""
    frame = finish_table(raw, scenes, samples)
    front = {"point": np.full(raw.shape[0], point, dtype=np.int64),
             "realization": np.arange(start, start + raw.shape[0], dtype=np.int64),
             **{key: np.array([d[key] for d in drawn_rows], dtype=float) for key in drawn_rows[0]}}
    for i, (key, values) in enumerate(front.items()):
        frame.insert(i, key, values)
    for key in next((m for m in intensities if m), {}):  # sa, pga
        frame[key] = np.array([m.get(key, np.nan) for m in intensities], dtype=float)
    return frame


@dataclass
class Plan:
    """Scenes of the sweep points and the chunks ``(point, start, stop)`` covering them."""

    scenes: list[Scene]
    chunks: list[tuple[int, int, int]]


def plan(study: Study, chunk: int | None = None, realizations: int | None = None,
         backend: str = "cpu") -> Plan:
    """Split every sweep point's realisations into chunks (``chunk`` 0 or None: automatic,
    from the scene's cost and the backend alone, so the plan is the same on any cluster or
    GPU).  With history statistics a chunk holds at most ``HISTORY_CHUNK_BYTES`` of paths
    (cuda: ``GPU_CHUNK_BYTES`` of paths and Poincare samples)."""
    scenes = [build_scene(s) for s in study.points]
    wanted = realizations or study.base.ensemble.realizations
    chunk = study.base.ensemble.chunk if chunk is None else chunk
    spec = study.base.simulation.history
    random = bool(study.base.uncertain)
    counts = [wanted if scene.has_noise or random else 1 for scene in scenes]
    chunks = []
    for p, (scene, n) in enumerate(zip(scenes, counts)):
        if backend == "cuda":
            size = chunk or min(n, GPU_CHUNK)
            row_bytes = 8 * (len(spec.signals) * hist.grid(scene.n_steps, spec.points)[1] if spec else 0)
            if scene.period > 0:
                row_bytes += 8 * POINCARE_SAMPLES * (2 * scene.mass.shape[0] + 2)
            size = min(size, max(1, GPU_CHUNK_BYTES // max(row_bytes, 1)))
        else:
            size = chunk or _auto_chunk(scene, n)
        if spec and backend != "cuda":
            row_bytes = 8 * len(spec.signals) * hist.grid(scene.n_steps, spec.points)[1]
            size = min(size, max(1, HISTORY_CHUNK_BYTES // row_bytes))
        chunks += [(p, s, min(s + size, n)) for s in range(0, n, size)]
    return Plan(scenes, chunks)


def _auto_chunk(scene: Scene, n: int) -> int:
    by_cost = max(1, CHUNK_STEPS // max(scene.n_steps, 1))
    return max(1, min(by_cost, math.ceil(n / CHUNKS_PER_POINT)))


def sample(study: Study, workers: int | None = None) -> pd.DataFrame:
    """Every realisation of every sweep point, in memory (no files, no history, no early
    stopping): the metric rows in point and realisation order."""
    the_plan = plan(study)
    base = study.base
    uncertain = study if base.uncertain else None

    def call(c: tuple[int, int, int]) -> tuple:
        return run_chunk, (the_plan.scenes[c[0]], base.ensemble.seed, *c, None, uncertain,
                           base.ensemble.common_random_numbers)

    done = dict(schedulers.embedded(the_plan.chunks, call, lambda c: False, workers or os.cpu_count() or 1))
    return pd.concat([_label(done[c][0], study, c[0]) for c in the_plan.chunks], ignore_index=True)


def _label(frame: pd.DataFrame, study: Study, point: int) -> pd.DataFrame:
    """Insert the swept values of ``point`` as columns after ``point`` and ``realization``."""
    for k in study.sweep_keys:
        frame.insert(2, k, study.grid[point][k])
    return frame


@dataclass
class PointState:
    """What the driver has folded of one sweep point, in realisation order."""

    chunks: list[tuple[int, int, int]]
    folded: int = 0                        # chunks folded
    stop: int | None = None                # realisations kept, once target_sem is met
    tree: hist.Tree | None = None
    edm: list[np.ndarray] = field(default_factory=list)  # per folded chunk: EDM, NaN when failed

    @property
    def done(self) -> bool:
        return self.stop is not None or self.folded == len(self.chunks)

    def fold(self, frame: pd.DataFrame, paths: np.ndarray | None, target: float | None) -> None:
        """Take the next chunk (``frame`` and ``paths`` are read only for ``target`` and the
        history tree); with ``target``, stop at the first multiple of ``TARGET_STEP``
        realisations whose EDM standard error is at most ``target``."""
        _, start, stop = self.chunks[self.folded]
        keep = stop - start
        if target is not None:
            edm = np.where(frame["status"].to_numpy() == "ok", frame["edm"].to_numpy(dtype=float), np.nan)
            self.edm.append(edm)
            n_stop = _stopping_count(np.concatenate(self.edm), start, target)
            if n_stop is not None:
                self.stop, keep = n_stop, n_stop - start
        if self.tree is not None:
            ok = (frame["status"] == "ok").to_numpy()
            self.tree.add(paths[:, :, :keep], ok[:keep])
        self.folded += 1

    def to_arrays(self) -> dict[str, np.ndarray]:
        """What a checkpoint keeps of the point, as named arrays (``restore`` takes it back)."""
        out = {"folded": np.array(self.folded), "stop": np.array(-1 if self.stop is None else self.stop),
               "edm": np.concatenate(self.edm) if self.edm else np.empty(0)}
        if self.tree is not None:
            out.update({f"tree.{name}": a for name, a in self.tree.to_arrays().items()})
        return out

    def restore(self, arrays: dict[str, np.ndarray]) -> None:
        """Take back what ``to_arrays`` gave (the EDM of the folded chunks joined into one: the
        same values in the same order)."""
        self.folded, stop = int(arrays["folded"]), int(arrays["stop"])
        if not 0 <= self.folded <= len(self.chunks):
            raise ValueError(f"{self.folded} chunks folded of {len(self.chunks)}")
        self.stop = None if stop < 0 else stop
        self.edm = [arrays["edm"]] if arrays["edm"].size else []
        if self.tree is not None:
            self.tree = hist.Tree.from_arrays({name.removeprefix("tree."): a for name, a in arrays.items()
                                               if name.startswith("tree.")})


def _stopping_count(edm: np.ndarray, start: int, target: float) -> int | None:
    """Smallest multiple ``n > start`` of ``TARGET_STEP`` within ``edm`` whose first ``n``
    realisations have an EDM standard error ``<= target`` (failed ones, NaN, left out)."""
    for n in range(TARGET_STEP * (start // TARGET_STEP + 1), edm.shape[0] + 1, TARGET_STEP):
        values = edm[:n][np.isfinite(edm[:n])]
        if values.size > 1 and np.std(values, ddof=1) / math.sqrt(values.size) <= target:
            return n
    return None


@contextmanager
def _client(scheduler: str, announce: bool = False) -> Iterator[object]:
    """A ``dask.distributed`` client connected to ``scheduler``: an address, or the path of a
    scheduler file (the JSON ``dask scheduler --scheduler-file`` writes); with ``announce``,
    the dashboard's address goes to standard error."""
    from dask.distributed import Client

    by_file = "://" not in scheduler and Path(scheduler).is_file()
    try:
        client = (Client(scheduler_file=scheduler, timeout="30s") if by_file
                  else Client(scheduler, timeout="30s"))
    except (OSError, TimeoutError, ValueError, KeyError) as exc:
        raise ValueError(f"{'--scheduler-file' if by_file else '--scheduler'} {scheduler}: {exc}") from None
    with client:
        if announce:
            print(f"dask.distributed at {client.scheduler.address}, dashboard {client.dashboard_link}",
                  file=sys.stderr)
        yield client


class _Checkpoint:
    """History statistics folded so far, saved atomically now and then as data
    (``store.write_arrays``: numeric arrays with the run key and their checksum, never pickles): a
    resumed run takes them up; chunks finished after the last save are run again for their paths."""

    def __init__(self, path: Path, key: str, every: float):
        self.path, self.key, self.every = path, key, every
        self.saved = time.monotonic()
        self.folded: set[tuple[int, int, int]] = set()  # the chunks the file holds

    def load(self, states: list[PointState]) -> None:
        """Restore ``states`` from the file, where there is one; ``ForeignFiles`` where it is
        another run's, damaged or not a checkpoint."""
        if not self.path.exists():
            return
        key, arrays = read_arrays(self.path)
        if key != self.key:
            raise ForeignFiles(f"{self.path}: the history statistics of another run; remove it (the chunks "
                               "of this run then run again for their paths), or use another --out folder")
        try:
            for p, state in enumerate(states):
                state.restore({name.split(".", 1)[1]: a for name, a in arrays.items()
                               if name.split(".", 1)[0] == str(p)})
        except (KeyError, ValueError, TypeError, IndexError) as exc:
            raise ForeignFiles(f"{self.path}: does not fit this run's chunks ({exc}); remove it") from None
        self._saved(states)

    def save(self, states: list[PointState], force: bool = False) -> None:
        if not force and time.monotonic() - self.saved < self.every:
            return
        write_arrays(self.path, {f"{p}.{name}": a for p, state in enumerate(states)
                                 for name, a in state.to_arrays().items()}, self.key)
        self.saved = time.monotonic()
        self._saved(states)

    def _saved(self, states: list[PointState]) -> None:
        self.folded = {c for state in states for c in state.chunks[:state.folded]}


class Interrupted(KeyboardInterrupt):
    """A run stopped by Ctrl-C: ``kept`` of its ``total`` chunks are in its folder for ``--resume``."""

    def __init__(self, kept: int, total: int):
        super().__init__(f"interrupted: {kept} of {total} chunks kept; finish with --resume")
        self.kept, self.total = kept, total


@contextmanager
def _noting_interrupts() -> Iterator[threading.Event]:
    """While a run in the main thread runs its chunks: Ctrl-C raises ``KeyboardInterrupt`` as
    always and is also noted in the event yielded, so that one lost on its way (raised inside a
    finaliser or a library's broad handler, where it is dropped) still stops the run.  Elsewhere
    (another thread; SIGINT handled or ignored by the caller) the event stays clear."""
    noted = threading.Event()
    if (threading.current_thread() is not threading.main_thread()
            or signal.getsignal(signal.SIGINT) is not signal.default_int_handler):
        yield noted
        return

    def note(signum: int, frame: object) -> None:
        noted.set()
        signal.default_int_handler(signum, frame)

    signal.signal(signal.SIGINT, note)
    try:
        yield noted
    finally:
        signal.signal(signal.SIGINT, signal.default_int_handler)


def output_directory(study: Study, directory: str | Path | None = None) -> Path:
    """Where a run writes: ``directory``, else the scenario's ``[output] directory``, else
    ``results/<name>``."""
    return Path(directory or study.base.output.directory or f"results/{study.base.name}")


def run(study: Study, directory: str | Path | None = None, *, workers: int | None = None,
        chunk: int | None = None, realizations: int | None = None, resume: bool = False,
        scheduler: str | None = None, progress: bool = False, checkpoint_seconds: float = 30.0,
        shard: tuple[int, int] | None = None,
        backend: str = "cpu") -> tuple[pd.DataFrame, pd.DataFrame] | None:
    """Run a validated study; write ``realizations.parquet``, ``summary.parquet`` (and
    ``history.parquet`` when ``simulation.history`` asks for it) into ``directory`` (default:
    the scenario's output directory) and return realisations and summary as DataFrames.

    ``workers``: threads of the embedded scheduler (default: all cores).  ``scheduler``: the
    address of a running ``dask.distributed`` scheduler to use instead, or the path of its
    scheduler file.  ``resume``: keep what
    a previous, interrupted run of the same scenario finished.  ``checkpoint_seconds``: how
    often the history statistics are saved for a resume.  ``shard = (i, n)``: run only the
    chunks whose index in the plan is ``i`` modulo ``n`` into the folder, write no results and
    return None (for job arrays: shards run side by side, then a ``resume`` run writes the
    results from their parts; not with history statistics, which need the paths).

    ``backend``: ``"cpu"`` (numba loops on CPU threads) or ``"cuda"`` (the same loops on an
    NVIDIA GPU, one realisation a thread: ``gpu.py``; its realisations draw from Philox streams,
    not the CPU's, so the two backends give two independent samples of the same law; where no
    GPU is, ``gpu.GPUUnavailable`` says why).

    The directory is owned by one run at a time (``store.lock_folder``): a run into a folder
    another live run writes is refused with ``store.FolderInUse``.  Every file the run writes
    carries its run key (``store.prepare_folder``): a new run deletes what earlier runs left and
    refuses (``store.ForeignFiles``) a folder holding files this program did not write; a resumed
    run refuses parts, results or a checkpoint of another run.  Ctrl-C raises ``Interrupted``
    (a ``KeyboardInterrupt``) saying how many chunks are kept.
    """
    if backend not in BACKENDS:
        raise ValueError(f"backend {backend!r}: must be one of {', '.join(BACKENDS)}")
    if backend == "cuda":
        from . import gpu

        gpu.require()
    if shard is not None:
        if not 0 <= shard[0] < shard[1]:
            raise ValueError(f"--shard {shard[0]}/{shard[1]}: give I/N with 0 <= I < N "
                             "(e.g. --shard 0/4)")
        if study.base.simulation.history:
            raise ValueError(f"--shard: {study.source} asks for history statistics, which are folded from "
                             "the paths of every realisation in order and cannot be split into shards; "
                             "run it in one job")
    directory = output_directory(study, directory)
    try:
        directory.mkdir(parents=True, exist_ok=True)
    except FileExistsError:
        raise NotADirectoryError(f"{directory}: exists and is not a folder") from None
    with lock_folder(directory, None if shard is None else f"shard-{shard[0]}-of-{shard[1]}"):
        return _run(study, directory, workers, chunk, realizations, resume, scheduler, progress,
                    checkpoint_seconds, shard, backend)


def _run(study: Study, directory: Path, workers: int | None, chunk: int | None, realizations: int | None,
         resume: bool, scheduler: str | None, progress: bool, checkpoint_seconds: float,
         shard: tuple[int, int] | None, backend: str) -> tuple[pd.DataFrame, pd.DataFrame] | None:
    """``run`` in a directory it owns."""
    base = study.base
    the_plan = plan(study, chunk, realizations, backend)
    seed, target, spec = base.ensemble.seed, base.ensemble.target_sem, base.simulation.history
    grids = [hist.grid(scene.n_steps, spec.points) if spec else None for scene in the_plan.scenes]
    key = run_key(study.text, the_plan.chunks, backend)
    keep = "--resume" if resume else "--shard" if shard is not None else None
    found = prepare_folder(directory, key, len(the_plan.chunks), study.source, keep)
    checkpoint = _Checkpoint(directory / "parts" / CHECKPOINT, key, checkpoint_seconds)
    states = [PointState([c for c in the_plan.chunks if c[0] == p], tree=hist.Tree() if spec else None)
              for p in range(len(the_plan.scenes))]
    if resume and spec:
        checkpoint.load(states)
    folded_chunks = {c for s in states for c in s.chunks[:s.folded]}
    # a part on disk is reused unless its history paths are still needed
    on_disk = {c for c in the_plan.chunks if part_path(directory, *c) in found}
    reusable = folded_chunks if spec else on_disk
    ready: dict[tuple[int, int, int], tuple[pd.DataFrame, np.ndarray | None]] = {}

    def fold_ready() -> None:
        for state in states:
            while not state.done:
                c = state.chunks[state.folded]
                if c in ready:
                    frame, paths = ready.pop(c)
                elif c in reusable and not spec:
                    frame, paths = (pd.read_parquet(part_path(directory, *c)) if target else None), None
                else:
                    break
                state.fold(frame, paths, target)

    mine = the_plan.chunks if shard is None else the_plan.chunks[shard[0]::shard[1]]
    todo = [c for c in mine if c not in reusable]
    total = sum(c[2] - c[1] for c in mine)
    done = total - sum(c[2] - c[1] for c in todo)
    chunk_runner = run_chunk_cuda if backend == "cuda" else run_chunk

    def call(c: tuple[int, int, int]) -> tuple:
        return chunk_runner, (the_plan.scenes[c[0]], seed, *c, grids[c[0]], study if base.uncertain else None,
                              base.ensemble.common_random_numbers,
                              tuple(spec.signals) if spec else hist.SIGNALS)

    def skip(c: tuple[int, int, int]) -> bool:
        return states[c[0]].done

    def kept() -> int:
        """Chunks of this run that a resumed run does not run again."""
        def held(c: tuple[int, int, int]) -> bool:
            return c in checkpoint.folded if spec else part_path(directory, *c).exists()

        return sum(held(c) or (states[c[0]].stop is not None and c[1] >= states[c[0]].stop) for c in mine)

    try:
        with ExitStack() as stack:
            interrupted = stack.enter_context(_noting_interrupts())
            fold_ready()
            bar = stack.enter_context(Progress(total, done, enabled=progress))
            if scheduler:
                client = stack.enter_context(_client(scheduler, progress))
                where = f"dask.distributed at {client.scheduler.address}"
                results = schedulers.distributed(client, todo, call, skip)
            else:  # (one GPU: its chunks one after the other)
                threads = 1 if backend == "cuda" else workers or os.cpu_count() or 1
                where, results = "embedded", schedulers.embedded(todo, call, skip, threads)
            stack.enter_context(closing(results))  # (its threads or futures stop before the client goes)
            if backend == "cuda":  # (the workers' GPUs of a cluster are theirs to name)
                from . import gpu

                where = f"{where}, cuda" + ("" if scheduler else f" ({gpu.device_name()})")
            folding = False
            try:
                for c, (frame, paths) in results:
                    _label(frame, study, c[0])
                    write_table(frame, part_path(directory, *c), {KEY: key})
                    ready[c] = (frame, paths)
                    folding = True
                    fold_ready()
                    folding = False
                    for rc in [rc for rc in ready if states[rc[0]].done]:
                        ready.pop(rc)
                    if spec:
                        checkpoint.save(states)
                    bar.advance(c[2] - c[1])
                    if interrupted.is_set():
                        raise KeyboardInterrupt
            except BaseException:
                if spec and not folding:  # keep what was folded, unless interrupted mid-fold
                    checkpoint.save(states, force=True)
                raise
            if interrupted.is_set():
                raise KeyboardInterrupt
        if shard is not None:
            return None
        meta = provenance(study.text, study.source, seed, where, backend, key)
        return _consolidate(study, the_plan, states, directory, meta, grids, spec)
    except KeyboardInterrupt as exc:
        raise Interrupted(kept(), len(mine)) from exc


def _consolidate(study: Study, the_plan: Plan, states: list[PointState], directory: Path,
                 meta: dict[str, str], grids: list[tuple[int, int] | None],
                 spec: History | None) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Gather the parts kept (up to each point's stopping count) into the result files."""
    frames = []
    for state in states:
        for c in state.chunks:
            if state.stop is not None and c[1] >= state.stop:
                break
            frame = pd.read_parquet(part_path(directory, *c))
            frames.append(frame if state.stop is None else frame[frame["realization"] < state.stop])
    realizations_df = pd.concat(frames, ignore_index=True)
    summary_df = summarise(realizations_df, study.sweep_keys, study.base.simulation.residual_tolerance)
    write_table(realizations_df, directory / "realizations.parquet", meta)
    write_table(summary_df, directory / "summary.parquet", meta)
    if spec:
        rows = []
        for p, (state, scene, grid) in enumerate(zip(states, the_plan.scenes, grids)):
            t = scene.dt * grid[0] * np.arange(grid[1])
            rows_p = hist.frame(state.tree.result(), spec, t)
            rows_p.insert(0, "point", p)
            for i, k in enumerate(study.sweep_keys):
                rows_p.insert(1 + i, k, study.grid[p][k])
            rows.append(rows_p)
        write_table(pd.concat(rows, ignore_index=True), directory / "history.parquet",
                    {**meta, "vines_stoch.history_block": str(hist.BLOCK)})
    return read_results(directory)


__all__ = ["METRICS", "generator", "plan", "run", "run_chunk", "sample"]
