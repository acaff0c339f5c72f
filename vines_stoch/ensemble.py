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

import json
import math
import os
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterator, Mapping
from contextlib import ExitStack, closing, contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from . import history as hist
from . import notices, psd, rare, schedulers, sensitivity
from .binding import binding
from .dynamics import refine_regimes
from .environment import memory_problem, require_cluster
from .kernels import DEFAULT_SIGNALS, kernel_for
from .kernels.chunk import chunk_loop, ground_paths, lane_scene, parameter_draws, seed_keys, simulate_chunk
from .kernels.lanes import LANES
from .metrics import METRICS, finish_table, ground_intensities, residual_warnings, summarise
from .notices import LOG
from .outputs import EVENT_COLUMNS, EVENT_T, Record
from .progress import Progress
from .results import Results, Solution, as_study, check_whole
from .rvt.table import with_estimates
from .scenario import History, Spectra, Study
from .scenario.fields import MAX_REALIZATIONS
from .scene import Scene, build_scene
from .signals import declare, signal_names
from .store import (
    CHECKPOINT,
    KEY,
    STUDIES,
    ForeignFiles,
    Saved,
    component,
    lock_folder,
    part_path,
    prepare_folder,
    provenance,
    read_arrays,
    run_key,
    write_arrays,
    write_table,
)
from .streams import generator

#: Target work of one chunk, in path-steps (about 0.1-0.3 s of compute).
CHUNK_STEPS = 5_000_000
#: Automatic chunks split a sweep point's ensemble into at least this many tasks ...
CHUNKS_PER_POINT = 32
#: ... each of at least this many path-steps (where the ensemble has them): a chunk's fixed
#: costs, its table and its Parquet part written and read back, are about 5-10 ms, the compute
#: of 0.2-0.5 M path-steps of contact under ground motion (200 paths of 30,000 steps: in
#: chunks of 7 paths, 7.0-9.0 M path-steps/s; of 34, 9.2-10.7).
MIN_CHUNK_STEPS = 1_000_000
#: Largest history paths buffer of one chunk, in bytes (caps the chunk size when history
#: statistics are asked for).
HISTORY_CHUNK_BYTES = 8_000_000
#: ``target_sem`` is tested at every multiple of this many realisations (and never before).
TARGET_STEP = 100
#: How many times cheaper a path-step of a scene in SIMD lanes counts in an automatic chunk's
#: work (``_auto_chunk``): lanes run about 3-4x faster than the scalar loop (``make bench``,
#: "Paths in SIMD lanes"), and a chunk's fixed costs (its table, its Parquet part) need about 3x
#: more compute beside them to stay small (measured on the smooth scene, 4,096 paths of 20,000
#: steps: 124, 158 and 151 M path-steps/s on one worker at 4, 16 and 64).  Not for a scene with
#: Hertz contact: the scalar step finishes its steps in contact and its events, and its lanes
#: run at about the scalar loop's speed (``make bench``: 1.03x on the contact-under-noise scene,
#: whose 256 paths made one chunk that a second worker could not share).
LANE_WORK = 16
#: Realisations of an automatic chunk of the cuda backend (a launch fills a large GPU from
#: about 1e5 threads on; ``gpu.simulate_many`` splits a chunk into launches that fit its memory).
GPU_CHUNK = 1 << 20
#: Largest history paths and Poincare samples of one cuda chunk on the host, in bytes.
GPU_CHUNK_BYTES = 1 << 29
#: Where ensembles run: ``run_chunk`` on CPU threads or ``run_chunk_cuda`` on an NVIDIA GPU.
BACKENDS = ("cpu", "cuda")


def chunk_parameters(study: Study, seed: int, point: int, start: int, stop: int,
                     common: bool = True) -> dict[str, np.ndarray]:
    """Values of the uncertain parameters of realisations ``start .. stop - 1``, by key in file
    order (one draw a parameter of each realisation's parameter stream, in one compiled call:
    ``kernels.chunk.parameter_draws``)."""
    dists = study.base.uncertain
    draws = np.zeros((stop - start, len(dists)))
    normal = np.array([d.normal for d in dists.values()], np.bool_)
    parameter_draws(seed_keys(seed), point, start, common, normal, draws)
    return {key: np.asarray(dist.value(draws[:, k]), dtype=float)
            for k, (key, dist) in enumerate(dists.items())}


def draw_parameters(study: Study, seed: int, point: int, realization: int,
                    common: bool = True) -> dict[str, float]:
    """Values of the uncertain parameters of one realisation, in file order (``chunk_parameters``)."""
    drawn = chunk_parameters(study, seed, point, realization, realization + 1, common)
    return {key: float(values[0]) for key, values in drawn.items()}


def run_chunk(scene: Scene, seed: int, point: int, start: int, stop: int,
              grid: tuple[int, int] | None = None, study: Study | None = None,
              common: bool = True,
              signals: tuple[str, ...] = DEFAULT_SIGNALS) -> tuple[pd.DataFrame, np.ndarray | None]:
    """Realisations ``start..stop-1`` of one sweep point: one metric row each and, when a
    history ``grid = (stride, size)`` is asked for, the paths of the history ``signals``
    ``(len(signals), size, stop - start)``.  The realisations run in one compiled call
    (``kernels.chunk.simulate_chunk``).  With ``study`` (a study with uncertain parameters) each
    realisation runs its own scene (``binding``: the point's scene with the drawn values set), its
    drawn values in columns named by their keys.
    ``common``: common random numbers across sweep points (see ``generator``)."""
    if study is None:
        drawn, scenes = {}, scene
        parts = [simulate_chunk(scene, seed, point, start, stop, common, grid, signals, scene.event_rows)]
    else:
        drawn = chunk_parameters(study, seed, point, start, stop, common)
        bound = binding(study, point)
        scenes = [bound.scene({key: float(values[j]) for key, values in drawn.items()})
                  for j in range(stop - start)]
        parts = [simulate_chunk(s, seed, point, r, r + 1, common, grid, signals, s.event_rows)
                 for r, s in zip(range(start, stop), scenes)]
    intensities = _intensities(scenes, seed, point, start, stop, common)
    raw, samples, history, events = (getattr(parts[0], name) if len(parts) == 1 else
                                     _stacked([getattr(part, name) for part in parts])
                                     for name in ("raw", "samples", "history", "events"))
    paths = None if grid is None else history.transpose(2, 1, 0)
    return _table(raw, scenes, samples, point, start, drawn, intensities, events), paths


def _stacked(parts: list[np.ndarray]) -> np.ndarray:
    """Realisations' output arrays one after the other, each padded with NaN to the longest's
    second axis (an uncertain forcing frequency changes how many Poincare samples a path keeps)."""
    if parts[0].ndim < 3:
        return np.concatenate(parts)
    longest = max(part.shape[1] for part in parts)
    return np.concatenate([np.pad(part, ((0, 0), (0, longest - part.shape[1]), (0, 0)),
                                  constant_values=np.nan) for part in parts])


def _intensities(scenes: Scene | list[Scene], seed: int, point: int, start: int, stop: int, common: bool,
                 philox: bool = False) -> dict[str, np.ndarray]:
    """``sa`` and ``pga`` of realisations ``start .. stop - 1`` (``scenes``: the point's, or one a
    realisation) from the ground paths they saw, their filter streams replayed (``ground_paths``:
    PCG64, or Philox where the scene runs in SIMD lanes, ``lane_scene``, and on the cuda backend,
    ``philox``); none where no scene asks."""
    def of(s: Scene, first: int, last: int) -> dict[str, np.ndarray]:
        paths = (ground_paths(s, seed, point, first, last, common, philox or lane_scene(s)) if s.im_period > 0
                 else None)
        return ground_intensities(s, paths)

    if isinstance(scenes, Scene):
        return of(scenes, start, stop)
    rows = [of(s, r, r + 1) for s, r in zip(scenes, range(start, stop))]
    return {key: np.concatenate([row[key] for row in rows]) for key in rows[0]} if rows else {}


def run_chunk_cuda(scene: Scene, seed: int, point: int, start: int, stop: int,
                   grid: tuple[int, int] | None = None, study: Study | None = None,
                   common: bool = True,
                   signals: tuple[str, ...] = DEFAULT_SIGNALS) -> tuple[pd.DataFrame, np.ndarray | None]:
    """``run_chunk`` on the GPU (``gpu.simulate_many``): the same table and paths, realisation
    ``r`` drawing from its Philox streams (``kernels/rng.py``) instead of the CPU's PCG64 streams
    (its uncertain parameters still come from the CPU's parameter stream)."""
    from . import gpu

    n = stop - start
    drawn = chunk_parameters(study, seed, point, start, stop, common) if study is not None else {}
    bound = binding(study, point) if study is not None else None
    scenes = ([bound.scene({key: float(values[j]) for key, values in drawn.items()}) for j in range(n)]
              if study is not None else scene)
    batch = gpu.simulate_many(scenes, seed, point, start, stop, common, grid, signals, scene.event_rows)
    intensities = _intensities(scenes, seed, point, start, stop, common, philox=True)
    paths = None if grid is None else batch.history.transpose(2, 1, 0)
    return _table(batch.raw, scenes, batch.samples, point, start, drawn, intensities, batch.events), paths


def _table(raw: np.ndarray, scenes: Scene | list[Scene], samples: np.ndarray, point: int, start: int,
           drawn: dict[str, np.ndarray], intensities: dict[str, np.ndarray],
           logs: np.ndarray) -> pd.DataFrame:
    """A chunk's table: point, realisation, drawn parameters (``drawn``: by key, one a row), the
    metrics (``finish_table``, ``samples``: the Poincare samples, ``(rows, samples, columns)``),
    then the intensity measures where the scene asks for them (``intensities``), and the event
    logs where it keeps them (``logs``: ``(rows, log rows, EVENT_COLUMNS)``), as list columns
    ``event_<column>`` (a chunk's part holds them; ``_events`` makes them events.parquet's rows)."""
    frame = finish_table(raw, scenes, samples if samples.shape[1] else None)
    first = scenes if isinstance(scenes, Scene) else scenes[0]
    refine_regimes(frame, scenes, samples, every=first.lyapunov)
    front = {"point": np.full(raw.shape[0], point, dtype=np.int64),
             "realization": np.arange(start, start + raw.shape[0], dtype=np.int64),
             **{key: np.asarray(values, dtype=float) for key, values in drawn.items()}}
    for i, (key, values) in enumerate(front.items()):
        frame.insert(i, key, values)
    for key, values in intensities.items():  # sa, pga
        frame[key] = values
    if logs.shape[1]:
        kept = [log[np.isfinite(log[:, EVENT_T])] for log in logs]
        for c, name in enumerate(EVENT_COLUMNS):
            frame[f"event_{name}"] = [log[:, c] for log in kept]
    if first.poincare and samples.shape[1]:
        names = poincare_columns(first.n_floors, first.mass.shape[0] - first.n_floors)
        each = [first] * raw.shape[0] if isinstance(scenes, Scene) else scenes
        k = np.arange(samples.shape[1], dtype=float)  # (the times of ``record_sample``)
        frame["poincare_period"] = [round(s.sample_from / s.period) + k for s in each]
        frame["poincare_t"] = [s.sample_from + k * s.period for s in each]
        for c, name in enumerate(names):
            frame[f"poincare_{name}"] = list(samples[:, :, c])
    return frame


def poincare_columns(n_floors: int, n_absorbers: int) -> list[str]:
    """The state columns of poincare.parquet, in the order of a Poincare sample row
    (``kernels.common.record_sample``): each floor's displacement (``x_k``, the lowest first),
    each absorber's (``xa_j``), then their velocities (``v_k``, ``va_j``), then the impacts on
    the left and right walls since the metrics window opened."""
    floors, absorbers = range(1, n_floors + 1), range(1, n_absorbers + 1)
    return ([f"x_{k}" for k in floors] + [f"xa_{j}" for j in absorbers] + [f"v_{k}" for k in floors]
            + [f"va_{j}" for j in absorbers] + ["impacts_left", "impacts_right"])


def _poincare(realizations: pd.DataFrame, sweep_keys: list[str]) -> tuple[pd.DataFrame, pd.DataFrame]:
    """The realisations table without its Poincare list columns (``_table``), and
    poincare.parquet's rows: point, the swept values, realisation, ``period`` (the forcing
    period's index: the sample is at ``t = period T``), ``t``, then the state
    (``poincare_columns``); samples the path did not reach (a window shorter than the samples
    it keeps) are left out."""
    rest, rows = _unlisted(realizations, sweep_keys, "poincare_")
    rows = rows[np.isfinite(rows["x_1"].to_numpy())].reset_index(drop=True)
    for c in ("period", "impacts_left", "impacts_right"):
        rows[c] = rows[c].astype(np.int64)
    return rest, rows


def _unlisted(realizations: pd.DataFrame, sweep_keys: list[str],
              prefix: str) -> tuple[pd.DataFrame, pd.DataFrame]:
    """The realisations table without its list columns ``<prefix><name>`` (``_table``: a list a
    realisation, the columns' lists of one length in a row), and their entries as rows: point,
    the swept values, realisation, then each list column (floats, named ``<name>``)."""
    listed = [c for c in realizations.columns if c.startswith(prefix)]
    counts = realizations[listed[0]].map(len).to_numpy()
    ids = ["point", *sweep_keys, "realization"]
    rows = pd.DataFrame({key: np.repeat(realizations[key].to_numpy(), counts) for key in ids})
    for c in listed:
        rows[c.removeprefix(prefix)] = np.concatenate([np.asarray(v, dtype=float) for v in realizations[c]]
                                                      or [[]])
    return realizations.drop(columns=listed), rows


def _events(realizations: pd.DataFrame, sweep_keys: list[str]) -> tuple[pd.DataFrame, pd.DataFrame]:
    """The realisations table without its event log columns (``_table``), and events.parquet's
    rows: point, the swept values, realisation, then each event's ``t``, ``absorber`` (from 1, in
    file order), ``wall`` (``"left"`` or ``"right"``), ``speed`` (the absorber's velocity relative
    to its host floor just before the event) and ``loss`` (the energy it took out)."""
    rest, events = _unlisted(realizations, sweep_keys, "event_")  # (t, absorber, side, speed, loss)
    events["absorber"] = events["absorber"].astype(np.int64) + 1
    events["side"] = pd.Series(["left", "right"], dtype="string").array.take(
        (events["side"].to_numpy() > 0).astype(np.intp))
    return rest, events.rename(columns={"side": "wall"})


@dataclass
class Plan:
    """Scenes of the sweep points and the chunks ``(point, start, stop)`` covering them."""

    scenes: list[Scene]
    chunks: list[tuple[int, int, int]]


def plan(study: Study, chunk: int | None = None, realizations: int | None = None,
         backend: str = "cpu", history: History | None = None) -> Plan:
    """Split every sweep point's realisations into chunks (``chunk`` 0 or None: automatic,
    from the scene's cost and the backend alone, so the plan is the same on any cluster or
    GPU).  With history statistics (or the time histories ``history``, where given, kept) a chunk
    holds at most ``HISTORY_CHUNK_BYTES`` of paths (cuda: ``GPU_CHUNK_BYTES`` of paths and
    Poincare samples)."""
    scenes = [build_scene(s) for s in study.points]
    wanted = study.base.ensemble.realizations if realizations is None else realizations
    chunk = study.base.ensemble.chunk if chunk is None else chunk
    spec = history or study.base.simulation.history
    spectra = study.base.output.spectra
    random = bool(study.base.uncertain)
    counts = [wanted if scene.has_noise or random else 1 for scene in scenes]
    chunks = []
    for p, (scene, n) in enumerate(zip(scenes, counts)):
        if backend == "cuda":
            size = chunk or min(n, GPU_CHUNK)
            row_bytes = _recorded_bytes(scene, spec, spectra)
            if scene.period > 0:
                row_bytes += 8 * scene.n_samples * (2 * scene.mass.shape[0] + 2)
            size = min(size, max(1, GPU_CHUNK_BYTES // max(row_bytes, 1)))
        else:  # (a chunk that keeps history rows, an event log or declared metrics: the scalar loop)
            kept = spec or spectra or scene.event_rows or scene.reductions.shape[0]
            in_lanes = lane_scene(scene) and not kept
            size = chunk or _auto_chunk(scene, n, in_lanes)
        if (spec or spectra) and backend != "cuda":
            row_bytes = _recorded_bytes(scene, spec, spectra)
            size = min(size, max(1, HISTORY_CHUNK_BYTES // row_bytes))
        chunks += [(p, s, min(s + size, n)) for s in range(0, n, size)]
    return Plan(scenes, chunks)


def recording(scene: Scene, history: History | None,
              spectra: Spectra | None) -> tuple[tuple[str, ...], tuple[int, int] | None]:
    """The signals a chunk's realisations record and their grid ``(stride, size)`` (None:
    none): the history's (``history``: statistics or the paths kept) on its grid, and with
    ``spectra`` theirs too, every step (the history's rows are then every ``stride``-th)."""
    signals = tuple(history.signals) if history else ()
    if spectra is None:
        return signals, hist.grid(scene.n_steps, history.points) if history else None
    return signals + tuple(s for s in spectra.signals if s not in signals), (1, scene.n_steps + 1)


def _recorded_bytes(scene: Scene, history: History | None, spectra: Spectra | None) -> int:
    """Bytes of one realisation's recorded signals (``recording``)."""
    signals, grid = recording(scene, history, spectra)
    return 8 * len(signals) * (grid[1] if grid else 0)


@dataclass(frozen=True)
class _View:
    """What the driver takes of a chunk's recorded paths (``recording``): the history's signals
    (``history``: how many, the first rows; 0: none) on its grid (every ``stride``-th row,
    ``size`` of them), and the spectra's (``spectra``: their rows) from row ``first`` (the
    metrics window), Welch segments of ``steps`` rows of ``dt``."""

    history: int
    stride: int
    size: int
    spectra: tuple[int, ...]
    first: int
    steps: int
    dt: float


def _view(scene: Scene, history: History | None, spectra: Spectra | None) -> _View | None:
    """The ``_View`` of a scene's chunks, or None where they are taken as recorded (no spectra)."""
    if spectra is None:
        return None
    signals, _ = recording(scene, history, spectra)
    stride, size = hist.grid(scene.n_steps, history.points) if history else (1, 0)
    return _View(len(history.signals) if history else 0, stride, size,
                 tuple(signals.index(s) for s in spectra.signals), scene.i0,
                 psd.segment_steps(scene.n_steps - scene.i0 + 1, spectra.segment, scene.dt), scene.dt)


def _chunk(runner, view: _View | None, *args) -> tuple[pd.DataFrame, np.ndarray | None, np.ndarray | None]:
    """``runner(*args)`` (``run_chunk`` or ``run_chunk_cuda``): the chunk's table, its paths of
    the history's signals on its grid, and with spectra each realisation's Welch estimates
    ``(signals, omega, n)`` (``psd.periodograms``), computed where the chunk ran."""
    frame, paths = runner(*args)
    if view is None:
        return frame, paths, None
    window = paths[list(view.spectra), view.first:, :]
    _, estimates = psd.periodograms(np.moveaxis(window, 2, 1), view.dt, view.steps)
    kept = paths[:view.history, ::view.stride, :][:, :view.size] if view.history else None
    return frame, kept, np.moveaxis(estimates, 1, 2)


def _auto_chunk(scene: Scene, n: int, lanes: bool) -> int:
    """Realisations of an automatic CPU chunk: ``CHUNK_STEPS`` of work at most, ``n /
    CHUNKS_PER_POINT`` where that leaves a chunk ``MIN_CHUNK_STEPS`` of work.  A chunk that runs
    in SIMD lanes (``lanes``: a scene of ``kernels.chunk.lane_scene`` whose run keeps no history
    rows, event log or declared metrics, which the scalar loop records) counts its path-steps
    ``LANE_WORK`` times cheaper and takes at least a batch of lanes (``lanes.LANES`` paths, or
    ``n``), its chunks then evened out (200 paths: two of 100, not 128 and 72); one with Hertz
    contact counts its path-steps at their scalar cost."""
    steps = max(scene.n_steps, 1)
    work = LANE_WORK if lanes and not scene.has_hertz else 1
    by_cost = max(1, work * CHUNK_STEPS // steps)
    least = math.ceil(work * MIN_CHUNK_STEPS / steps)
    size = max(1, min(by_cost, n, max(math.ceil(n / CHUNKS_PER_POINT), least)))
    if lanes and n > 0:
        size = max(size, min(n, LANES))
        size = math.ceil(n / math.ceil(n / size))
    return size


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
    spectrum: psd.Spectrum | None = None   # the spectra's running sums

    @property
    def done(self) -> bool:
        return self.stop is not None or self.folded == len(self.chunks)

    def fold(self, frame: pd.DataFrame, paths: np.ndarray | None, target: float | None,
             estimates: np.ndarray | None = None) -> None:
        """Take the next chunk (``frame``, ``paths`` and the spectral ``estimates`` are read
        only for ``target``, the history tree and the spectra); with ``target``, stop at the
        first multiple of ``TARGET_STEP`` realisations whose EDM standard error is at most
        ``target``.  Failed realisations count in neither the tree nor the spectra."""
        _, start, stop = self.chunks[self.folded]
        keep = stop - start
        if target is not None:
            edm = np.where(frame["status"].to_numpy() == "ok", frame["edm"].to_numpy(dtype=float), np.nan)
            self.edm.append(edm)
            n_stop = _stopping_count(np.concatenate(self.edm), start, target)
            if n_stop is not None:
                self.stop, keep = n_stop, n_stop - start
        if self.tree is not None or self.spectrum is not None:
            ok = (frame["status"] == "ok").to_numpy()[:keep]
            if self.tree is not None:
                self.tree.add(paths[:, :, :keep], ok)
            if self.spectrum is not None:
                self.spectrum.add(estimates[:, :, :keep][:, :, ok])
        self.folded += 1

    def to_arrays(self) -> dict[str, np.ndarray]:
        """What a checkpoint keeps of the point, as named arrays (``restore`` takes it back)."""
        out = {"folded": np.array(self.folded), "stop": np.array(-1 if self.stop is None else self.stop),
               "edm": np.concatenate(self.edm) if self.edm else np.empty(0)}
        if self.tree is not None:
            out.update({f"tree.{name}": a for name, a in self.tree.to_arrays().items()})
        if self.spectrum is not None:
            out.update({f"spectrum.{name}": a for name, a in self.spectrum.to_arrays().items()})
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
        if self.spectrum is not None:
            self.spectrum = psd.Spectrum.from_arrays({name.removeprefix("spectrum."): a
                                                      for name, a in arrays.items()
                                                      if name.startswith("spectrum.")})


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
    if by_file:
        try:
            address = json.loads(Path(scheduler).read_text(errors="replace")).get("address")
        except (ValueError, AttributeError, OSError):
            address = None
        if not isinstance(address, str):
            raise ValueError(f"--scheduler-file {scheduler}: not a dask scheduler file (the JSON with an "
                             "'address' that dask scheduler --scheduler-file FILE writes)")
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
    ``results/<name>`` (the name as one path component: ``store.component``)."""
    return Path(directory or study.base.output.directory or Path("results") / component(study.base.name))


def _check_arguments(out: object, workers: object, chunk: object, realizations: object, paths: object,
                     checkpoint_seconds: object, backend: object, shard: object = None,
                     scheduler: object = None) -> None:
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


def run(scenario: Study | Mapping[str, Any] | str | os.PathLike, out: str | Path | None = None, *,
        workers: int | None = None, chunk: int | None = None, realizations: int | None = None,
        paths: bool = False, resume: bool = False, scheduler: str | None = None, progress: bool = False,
        checkpoint_seconds: float = 30.0, shard: tuple[int, int] | None = None,
        backend: str = "cpu", overwrite: bool = False) -> Results | None:
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
    GPU is, ``gpu.GPUUnavailable`` says why).

    The directory is owned by one run at a time (``store.lock_folder``): a run into a folder
    another live run writes is refused with ``store.FolderInUse``.  Every file the run writes
    carries its run key (``store.prepare_folder``): a new run deletes what earlier runs left and
    refuses (``store.ForeignFiles``) a folder holding files this program did not write; a resumed
    run refuses parts, results or a checkpoint of another run.  Ctrl-C raises ``Interrupted``
    (a ``KeyboardInterrupt``) saying how many chunks are kept.
    """
    _check_arguments(out, workers, chunk, realizations, paths, checkpoint_seconds, backend, shard, scheduler)
    scheduler = None if scheduler is None else os.fspath(scheduler)
    study = as_study(scenario)
    if backend == "cuda":
        from . import gpu

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
                       shard, backend, overwrite)
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


def structure(scene: Scene) -> str:
    """The structure a step loop is compiled for, in words (its scheme, bodies, floors and what
    the loop carries)."""
    features = [name for name, present in (("impacts", scene.has_impact), ("Hertz contact", scene.has_hertz),
                                           ("white noise", scene.has_white_noise),
                                           ("filtered loads", scene.has_filters),
                                           ("ground motion", scene.has_ground),
                                           ("geometric absorber", scene.has_geometric)) if present]
    return (f"{scene.scheme} loop, {scene.mass.shape[0]} bodies, {scene.n_floors} floor(s)"
            + "".join(f", {f}" for f in features))


def prepare_loops(scenes: list[Scene], seed: int, common: bool, grid: tuple[int, int] | None = None,
                  signals: tuple[str, ...] = DEFAULT_SIGNALS, show: bool = True) -> None:
    """Compile (or load from numba's cache on disk) the step loop of each structure among
    ``scenes`` that this process has not run yet, before any chunk starts, with one line each
    (logged at INFO on the ``vines_stoch`` logger, and with ``show`` on standard error): which
    structure, and whether it was compiled (once: later runs load it) or loaded.  A chunk of no
    realisations runs each loop with the argument types of ``run_chunk``."""
    seen = set()
    for point, scene in enumerate(scenes):
        columns = declare(signals, scene.n_floors, scene.kind.shape[0]) if grid else None
        record = Record.of(scene, grid[1] if grid else 0, scene.event_rows, columns)
        run = chunk_loop(kernel_for(scene, record=record))
        if run in seen or run.overloads:
            continue
        seen.add(run)
        if show:
            print(f"step loop: {structure(scene)}: compiling or loading ...", end="", file=sys.stderr,
                  flush=True)
        hits, start = sum(run.stats.cache_hits.values()), time.monotonic()
        simulate_chunk(scene, seed, point, 0, 0, common, grid, signals, scene.event_rows)
        loaded = sum(run.stats.cache_hits.values()) > hits
        outcome = (f"{'loaded from the cache' if loaded else 'compiled (cached on disk for later runs)'} "
                   f"in {time.monotonic() - start:.1f} s")
        LOG.info("step loop: %s: %s", structure(scene), outcome)
        if show:
            print(f" {outcome}", file=sys.stderr, flush=True)


def _run(study: Study, directory: Path | None, o: _Options) -> Results | None:
    """``run`` in a directory it owns, or in memory (``directory`` None)."""
    base = study.base
    spec, spectra = base.simulation.history, base.output.spectra
    tracked = bool(spec or spectra)  # (folded from every realisation's paths, in order)
    grid_spec = spec or (History() if o.paths else None)  # (the grid of the paths kept)
    the_plan = plan(study, o.chunk, o.realizations, o.backend, grid_spec)
    seed, target = base.ensemble.seed, base.ensemble.target_sem
    signals = tuple(grid_spec.signals) if grid_spec else DEFAULT_SIGNALS
    grids = [hist.grid(scene.n_steps, grid_spec.points) if grid_spec else None for scene in the_plan.scenes]
    recorded = [recording(scene, grid_spec, spectra) for scene in the_plan.scenes]
    views = [_view(scene, grid_spec, spectra) for scene in the_plan.scenes]
    key = run_key(study.text, the_plan.chunks, o.backend)
    keep = "--resume" if o.resume else "--shard" if o.shard is not None else None
    found = set() if directory is None else prepare_folder(directory, key, len(the_plan.chunks), study.source,
                                                           keep, o.overwrite)
    checkpoint = None if directory is None else _Checkpoint(directory / "parts" / CHECKPOINT, key,
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
    chunk_runner = run_chunk_cuda if o.backend == "cuda" else run_chunk

    def call(c: tuple[int, int, int]) -> tuple:
        signals_c, grid_c = recorded[c[0]]
        return _chunk, (chunk_runner, views[c[0]], the_plan.scenes[c[0]], seed, *c, grid_c,
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
                          recorded[0][0] or DEFAULT_SIGNALS, show=o.progress)
        with ExitStack() as stack:
            interrupted = stack.enter_context(_noting_interrupts())
            fold_ready()
            bar = stack.enter_context(Progress(total, done, enabled=o.progress))
            if o.scheduler:
                client = stack.enter_context(_client(o.scheduler, o.progress))
                where = f"dask.distributed at {client.scheduler.address}"
                results = schedulers.distributed(client, todo, call, skip)
            else:  # (one GPU: its chunks one after the other)
                threads = 1 if o.backend == "cuda" else o.workers or os.cpu_count() or 1
                where, results = "embedded", schedulers.embedded(todo, call, skip, threads)
            stack.enter_context(closing(results))  # (its threads or futures stop before the client goes)
            if o.backend == "cuda":  # (the workers' GPUs of a cluster are theirs to name)
                from . import gpu

                where = f"{where}, cuda" + ("" if o.scheduler else f" ({gpu.device_name()})")
            folding = False
            try:
                for c, (frame, chunk_paths, estimates) in results:
                    _label(frame, study, c[0])
                    frames[c] = frame  # (the consolidation's rows: its part is not read back)
                    if directory is not None:
                        write_table(frame, part_path(directory, *c), {KEY: key})
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
        meta = provenance(study.text, study.source, seed, where, o.backend, key)
        chosen = _chosen_paths(study, the_plan, states, chunk_runner) if base.output.paths else None
        studies = {}
        saved = Saved(None if directory is None else directory / "parts" / STUDIES, key, o.resume)
        if base.rare is not None:
            studies["rare"] = rare.table(study, _scene_of(study), o.progress,
                                         lambda point, values: binding(study, point).scene(values), saved,
                                         o.backend)
        if base.sensitivity is not None:
            studies["sensitivity"] = sensitivity.table(study, _design_output(study, chunk_runner), o.progress,
                                                       saved)
        return _consolidate(study, the_plan, states, directory, frames, meta, grids, spec,
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


def _consolidate(study: Study, the_plan: Plan, states: list[PointState], directory: Path | None,
                 frames: dict[tuple[int, int, int], pd.DataFrame], meta: dict[str, str],
                 grids: list[tuple[int, int] | None], spec: History | None,
                 kept_paths: dict[tuple[int, int, int], np.ndarray] | None,
                 signals: tuple[str, ...], views: list[_View | None], chosen: pd.DataFrame | None,
                 studies: dict[str, pd.DataFrame] | None = None) -> Results:
    """Gather the chunks kept (up to each point's stopping count: from ``frames`` in memory, the
    chunks this run ran, else the folder's parts, an earlier run's) into the result tables, and
    the points' history statistics and spectra (``views``: their Welch segments), written into
    ``directory`` where there is one, with the paths of the realisations ``[output] paths``
    chooses (``chosen``, ``_chosen_paths``; the results' ``paths`` unless ``kept_paths`` holds
    every realisation's) and the tables of the studies beside the ensemble (``studies``: ``rare``
    and ``sensitivity``, by name)."""
    studies = {name: _in_file_types(frame) for name, frame in (studies or {}).items()}
    kept, path_rows = [], []
    for state in states:
        for c in state.chunks:
            if state.stop is not None and c[1] >= state.stop:
                break
            frame = frames[c] if c in frames else pd.read_parquet(part_path(directory, *c))
            n = len(frame) if state.stop is None else min(len(frame), state.stop - c[1])
            kept.append(frame.iloc[:n])
            if kept_paths is not None:
                path_rows.append(_path_rows(study, the_plan.scenes[c[0]], grids[c[0]], c,
                                            kept_paths[c][:, :, :n], signals))
    realizations_df = _in_file_types(kept[0] if len(kept) == 1 else pd.concat(kept, ignore_index=True))
    events_df = None
    if "event_t" in realizations_df.columns:
        realizations_df, events_df = _events(realizations_df, study.sweep_keys)
    poincare_df = None
    if "poincare_t" in realizations_df.columns:
        realizations_df, poincare_df = _poincare(realizations_df, study.sweep_keys)
    summary_df = with_estimates(summarise(realizations_df, study.sweep_keys,
                                          study.base.simulation.residual_tolerance), study)
    def by_point(rows: list[pd.DataFrame]) -> pd.DataFrame:
        """Each point's rows after its index and swept values, one table."""
        for p, rows_p in enumerate(rows):
            rows_p.insert(0, "point", p)
            for i, k in enumerate(study.sweep_keys):
                rows_p.insert(1 + i, k, study.grid[p][k])
        return pd.concat(rows, ignore_index=True)

    history_df = spectra_df = None
    if spec:
        history_df = by_point([hist.frame(state.tree.result(), spec, scene.dt * grid[0] * np.arange(grid[1]))
                               for state, scene, grid in zip(states, the_plan.scenes, grids)])
    spectra = study.base.output.spectra
    if spectra:
        spectra_df = by_point([state.spectrum.frame(psd.frequencies(view.steps, view.dt),
                                                    tuple(spectra.signals))
                               for state, view in zip(states, views)])
    # the tables as written and read back (``_in_file_types``): the results a run returns, in
    # memory or from its folder, are those ``read_results`` of the folder gives
    summary_df, history_df, events_df, poincare_df, spectra_df, chosen = (
        None if frame is None else _in_file_types(frame)
        for frame in (summary_df, history_df, events_df, poincare_df, spectra_df, chosen))
    paths_df = _in_file_types(pd.concat(path_rows, ignore_index=True)) if kept_paths is not None else chosen
    if directory is not None:
        files = {"realizations": realizations_df, "summary": summary_df, "history": history_df,
                 "events": events_df, "poincare": poincare_df, "spectra": spectra_df, "paths": chosen,
                 **studies}
        for name, frame in files.items():
            if frame is not None:
                extra = {"vines_stoch.history_block": str(hist.BLOCK)} if name == "history" else {}
                write_table(frame, directory / f"{name}.parquet", {**meta, **extra})
    return Results(realizations_df, summary_df, history_df, paths_df, meta, directory, study, events_df,
                   poincare_df, spectra_df, studies.get("rare"), studies.get("sensitivity"))


def _in_file_types(frame: pd.DataFrame) -> pd.DataFrame:
    """``frame`` with the column types it has once written as Parquet and read back (an Arrow
    table in memory): results in memory and from a folder compare equal.  Numpy bool, integer
    and float columns come back as they are (the same type and bits), so only the others make
    the round trip."""
    import pyarrow as pa

    other = [c for c, dtype in frame.dtypes.items()
             if not (isinstance(dtype, np.dtype) and dtype.kind in "biuf")]
    frame = frame.reset_index(drop=True)
    if other:
        back = pa.Table.from_pandas(frame[other], preserve_index=False).to_pandas()
        frame = frame.assign(**{c: back[c] for c in other})  # (in place of each, order kept)
    return frame


def _chosen_paths(study: Study, the_plan: Plan, states: list[PointState], runner) -> pd.DataFrame:
    """paths.parquet's rows (``[output] paths``): the realisations it chooses of every sweep
    point (those the point kept: ``target_sem`` may stop it earlier) run again by ``runner``
    (``run_chunk`` or ``run_chunk_cuda``), on the same streams as in the ensemble, so the same
    paths, with its signals on its grid (``_path_rows``)."""
    base, chosen = study.base, study.base.output.paths
    signals = tuple(chosen.signals)
    rows = []
    for p, (scene, state) in enumerate(zip(the_plan.scenes, states)):
        count = state.stop if state.stop is not None else state.chunks[-1][2]
        grid = hist.grid(scene.n_steps, chosen.points)
        for r in (r for r in chosen.realizations if r < count):
            _, paths = runner(scene, base.ensemble.seed, p, r, r + 1, grid, study if base.uncertain else None,
                              base.ensemble.common_random_numbers, signals)
            rows.append(_path_rows(study, scene, grid, (p, r, r + 1), paths, signals))
    return _in_file_types(pd.concat(rows, ignore_index=True))


def _path_rows(study: Study, scene: Scene, grid: tuple[int, int], c: tuple[int, int, int],
               paths: np.ndarray, signals: tuple[str, ...]) -> pd.DataFrame:
    """The time histories ``paths`` (``(signals, grid, n)``) of the realisations of chunk ``c``
    as rows: point, swept values, realisation, ``t``, one column per signal."""
    n, size = paths.shape[2], grid[1]
    rows = {"point": np.full(n * size, c[0], dtype=np.int64),
            **{k: np.repeat(study.grid[c[0]][k], n * size) for k in study.sweep_keys},
            "realization": np.repeat(np.arange(c[1], c[1] + n, dtype=np.int64), size),
            "t": np.tile(scene.dt * grid[0] * np.arange(size), n)}
    for i, name in enumerate(signals):
        rows[name] = paths[i].T.reshape(-1)
    return pd.DataFrame(rows)


def solve(scenario: Study | Mapping[str, Any] | str | os.PathLike, *, point: int = 0, realization: int = 0,
          points: int | None = None, signals: list[str] | tuple[str, ...] | None = None) -> Solution:
    """One realisation of a scenario with its time histories (``Solution``: ``ts``, ``ys`` by
    signal name, and its metrics, the same values as realisation ``realization`` of sweep point
    ``point`` in an ensemble run).  ``points``: rows of the time grid (default: every step);
    ``signals``: any of ``signals.signal_names`` (default ``x1``, ``e1``)."""
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
    frame, paths = run_chunk(scene, base.ensemble.seed, point, realization, realization + 1, grid,
                             study if base.uncertain else None, base.ensemble.common_random_numbers, signals)
    _label(frame, study, point)
    ys = {s: paths[i, :, 0] for i, s in enumerate(signals)}
    return Solution(scene.dt * grid[0] * np.arange(grid[1]), ys, frame.iloc[0], point, realization, study)


__all__ = ["METRICS", "generator", "plan", "run", "run_chunk", "sample", "solve"]
