"""A chunk: realisations ``start .. stop - 1`` of one sweep point run in one compiled call, on
the CPU (``run_chunk``) or the GPU (``run_chunk_cuda``), as one table (metrics, drawn parameters,
intensity measures, event logs, Poincare samples) and the recorded signals' paths."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from .. import history as hist
from .. import psd
from ..binding import binding
from ..dynamics import refine_regimes
from ..kernels import (
    DEFAULT_SIGNALS,
    general_run,
    ground_paths,
    lane_scene,
    parameter_draws,
    seed_keys,
    simulate_chunk,
)
from ..metrics import finish_table, ground_intensities
from ..outputs import EVENT_COLUMNS, EVENT_T
from ..scenario import History, Spectra, Study
from ..scene import Scene


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
              common: bool = True, signals: tuple[str, ...] = DEFAULT_SIGNALS,
              executor: str = "lanes", general: bool | None = None) -> tuple[pd.DataFrame, np.ndarray | None]:
    """Realisations ``start..stop-1`` of one sweep point: one metric row each and, when a
    history ``grid = (stride, size)`` is asked for, the paths of the history ``signals``
    ``(len(signals), size, stop - start)``.  The realisations run in one compiled call of
    ``executor`` (``kernels.EXECUTORS``, ``kernels.simulate_chunk``; ``general``: in a loop
    compiled once for every structure, the pass loop where it takes the chunk
    (``kernels.in_pass_loop``) or else the scheme's general loop, the same numbers; by default
    where the chunk's work asks, ``kernels.general_run``).
    With ``study`` (a study with uncertain parameters) each realisation runs its own scene
    (``binding``: the point's scene with the drawn values set), its drawn values in columns named
    by their keys.
    ``common``: common random numbers across sweep points (see ``generator``)."""
    if general is None:
        general = general_run(scene.n_steps * (stop - start))
    if study is None:
        drawn, scenes = {}, scene
        parts = [simulate_chunk(scene, seed, point, start, stop, common, grid, signals, scene.event_rows,
                                executor, general=general)]
    else:
        drawn = chunk_parameters(study, seed, point, start, stop, common)
        bound = binding(study, point)
        scenes = [bound.scene({key: float(values[j]) for key, values in drawn.items()})
                  for j in range(stop - start)]
        parts = [simulate_chunk(s, seed, point, r, r + 1, common, grid, signals, s.event_rows, executor,
                                general=general) for r, s in zip(range(start, stop), scenes)]
    intensities = _intensities(scenes, seed, point, start, stop, common, executor=executor)
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
                 philox: bool = False, executor: str = "lanes") -> dict[str, np.ndarray]:
    """``sa`` and ``pga`` of realisations ``start .. stop - 1`` (``scenes``: the point's, or one a
    realisation) from the ground paths they saw, their filter streams replayed (``ground_paths``:
    PCG64, or Philox where the scene runs in SIMD lanes under ``executor``, ``lane_scene``, and on
    the cuda backend, ``philox``); none where no scene asks."""
    def of(s: Scene, first: int, last: int) -> dict[str, np.ndarray]:
        in_philox = philox or lane_scene(s, executor)
        paths = ground_paths(s, seed, point, first, last, common, in_philox) if s.im_period > 0 else None
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
    ``r`` drawing from its Philox streams (``streams/rng.py``) instead of the CPU's PCG64 streams
    (its uncertain parameters still come from the CPU's parameter stream)."""
    from .. import gpu

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
    ``event_<column>`` (a chunk's part holds them; ``tables._events`` makes them events.parquet's rows)."""
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


def recording(scene: Scene, history: History | None,
              spectra: Spectra | None) -> tuple[tuple[str, ...], tuple[int, int] | None]:
    """The signals a chunk's realisations record and their grid ``(stride, size)`` (None:
    none): the history's (``history``: statistics or the paths kept) on its grid, and with
    ``spectra`` theirs too, every step (the history's rows are then every ``stride``-th)."""
    signals = tuple(history.signals) if history else ()
    if spectra is None:
        return signals, hist.grid(scene.n_steps, history.points) if history else None
    return signals + tuple(s for s in spectra.signals if s not in signals), (1, scene.n_steps + 1)


def recorded_bytes(scene: Scene, history: History | None, spectra: Spectra | None) -> int:
    """Bytes of one realisation's recorded signals (``recording``)."""
    signals, grid = recording(scene, history, spectra)
    return 8 * len(signals) * (grid[1] if grid else 0)


@dataclass(frozen=True)
class View:
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


def view_of(scene: Scene, history: History | None, spectra: Spectra | None) -> View | None:
    """The ``View`` of a scene's chunks, or None where they are taken as recorded (no spectra)."""
    if spectra is None:
        return None
    signals, _ = recording(scene, history, spectra)
    stride, size = hist.grid(scene.n_steps, history.points) if history else (1, 0)
    return View(len(history.signals) if history else 0, stride, size,
                 tuple(signals.index(s) for s in spectra.signals), scene.i0,
                 psd.segment_steps(scene.n_steps - scene.i0 + 1, spectra.segment, scene.dt), scene.dt)


def run_viewed(runner, view: View | None, *args) -> tuple[pd.DataFrame, np.ndarray | None, np.ndarray | None]:
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
