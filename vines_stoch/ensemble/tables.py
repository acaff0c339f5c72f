"""Consolidation: the chunks kept gathered into the result tables (realisations, summary,
history statistics, spectra, events, Poincare samples, chosen paths) and written to the folder."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from .. import history as hist
from .. import psd, store
from ..metrics import summarise
from ..results import Results
from ..rvt.table import with_estimates
from ..scenario import History, Study
from ..scene import Scene
from ..store import part_path
from .chunks import View
from .folding import PointState
from .planning import Plan


def label_points(frame: pd.DataFrame, study: Study, point: int) -> pd.DataFrame:
    """Insert the swept values of ``point`` as columns after ``point`` and ``realization``."""
    for k in study.sweep_keys:
        frame.insert(2, k, study.grid[point][k])
    return frame


def _poincare(realizations: pd.DataFrame, sweep_keys: list[str]) -> tuple[pd.DataFrame, pd.DataFrame]:
    """The realisations table without its Poincare list columns (``chunks._table``), and
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
    """The realisations table without its list columns ``<prefix><name>`` (``chunks._table``: a list a
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
    """The realisations table without its event log columns (``chunks._table``), and events.parquet's
    rows: point, the swept values, realisation, then each event's ``t``, ``absorber`` (from 1, in
    file order), ``wall`` (``"left"`` or ``"right"``), ``speed`` (the absorber's velocity relative
    to its host floor just before the event) and ``loss`` (the energy it took out)."""
    rest, events = _unlisted(realizations, sweep_keys, "event_")  # (t, absorber, side, speed, loss)
    events["absorber"] = events["absorber"].astype(np.int64) + 1
    events["side"] = pd.Series(["left", "right"], dtype="string").array.take(
        (events["side"].to_numpy() > 0).astype(np.intp))
    return rest, events.rename(columns={"side": "wall"})


def consolidate(study: Study, the_plan: Plan, states: list[PointState], directory: Path | None,
                 frames: dict[tuple[int, int, int], pd.DataFrame], meta: dict[str, str],
                 grids: list[tuple[int, int] | None], spec: History | None,
                 kept_paths: dict[tuple[int, int, int], np.ndarray] | None,
                 signals: tuple[str, ...], views: list[View | None], chosen: pd.DataFrame | None,
                 studies: dict[str, pd.DataFrame] | None = None) -> Results:
    """Gather the chunks kept (up to each point's stopping count: from ``frames`` in memory, the
    chunks this run ran, else the folder's parts, an earlier run's) into the result tables, and
    the points' history statistics and spectra (``views``: their Welch segments), written into
    ``directory`` where there is one, with the paths of the realisations ``[output] paths``
    chooses (``chosen``, ``chosen_paths``; the results' ``paths`` unless ``kept_paths`` holds
    every realisation's) and the tables of the studies beside the ensemble (``studies``: ``rare``
    and ``sensitivity``, by name)."""
    studies = {name: in_file_types(frame) for name, frame in (studies or {}).items()}
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
    realizations_df = in_file_types(kept[0] if len(kept) == 1 else pd.concat(kept, ignore_index=True))
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
    # the tables as written and read back (``in_file_types``): the results a run returns, in
    # memory or from its folder, are those ``read_results`` of the folder gives
    summary_df, history_df, events_df, poincare_df, spectra_df, chosen = (
        None if frame is None else in_file_types(frame)
        for frame in (summary_df, history_df, events_df, poincare_df, spectra_df, chosen))
    paths_df = in_file_types(pd.concat(path_rows, ignore_index=True)) if kept_paths is not None else chosen
    if directory is not None:
        files = {"realizations": realizations_df, "summary": summary_df, "history": history_df,
                 "events": events_df, "poincare": poincare_df, "spectra": spectra_df, "paths": chosen,
                 **studies}
        for name, frame in files.items():
            if frame is not None:
                extra = {"vines_stoch.history_block": str(hist.BLOCK)} if name == "history" else {}
                store.write_table(frame, directory / f"{name}.parquet", {**meta, **extra})
    return Results(realizations_df, summary_df, history_df, paths_df, meta, directory, study, events_df,
                   poincare_df, spectra_df, studies.get("rare"), studies.get("sensitivity"))


def in_file_types(frame: pd.DataFrame) -> pd.DataFrame:
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


def chosen_paths(study: Study, the_plan: Plan, states: list[PointState], runner) -> pd.DataFrame:
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
    return in_file_types(pd.concat(rows, ignore_index=True))


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
