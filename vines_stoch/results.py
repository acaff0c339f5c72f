"""What a run gives back: ``Results`` (the tables of an ensemble, in memory or read from its
folder) and ``Solution`` (the time histories of one realisation), and the scenario given to
``run`` as a path, a dict or a validated ``Study``.

Every quantity is in the units of the scenario file, SI by default (m, kg, s, N, J, rad/s):
the program never converts units, so a file written in other consistent units gives its
results in those (README, "Python API").
"""

from __future__ import annotations

import os
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from .scenario import ScenarioError, Study, load_scenario, parse_scenario


def as_study(scenario: Study | Mapping[str, Any] | str | os.PathLike) -> Study:
    """``scenario`` as a validated Study: a Study as it is, a path read as a scenario file, a
    dict of the file's tables validated as one (named ``<dict>`` in messages); ``TypeError``
    for anything else, ``ScenarioError`` for a scenario with mistakes."""
    if isinstance(scenario, Study):
        return scenario
    if isinstance(scenario, (str, os.PathLike)):
        return load_scenario(scenario)
    if isinstance(scenario, Mapping):
        import tomlkit

        from .scenario.study import _check_depth

        _check_depth(dict(scenario), "<dict>")  # (before tomlkit walks it by recursion)
        try:
            source = tomlkit.dumps(dict(scenario))
        except (TypeError, ValueError) as exc:  # (a value TOML cannot hold)
            raise ScenarioError(f"<dict>: not a scenario's tables ({exc})") from None
        return parse_scenario(source, "<dict>")
    raise TypeError(f"scenario = {_shown(scenario)}: give a scenario file's path, a dict of its tables "
                    "or a Study (load_scenario)")


def _shown(value: object) -> str:
    """A value as named in a message: its repr, cut to 60 characters, and its type."""
    text = repr(value)
    return f"{text if len(text) <= 60 else text[:57] + '...'} ({type(value).__name__})"


def check_whole(name: str, value: object, low: int, high: int | None = None,
                allow_none: bool = True) -> None:
    """Refuse ``value`` for the argument ``name`` unless it is a whole number in ``[low, high]``
    (or None where ``allow_none``): ``TypeError`` for another type, ``ValueError`` out of range,
    each naming the argument, the value and the range."""
    if value is None and allow_none:
        return
    span = f"[{low}, {high}]" if high is not None else f">= {low}"
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"{name} = {_shown(value)}: must be a whole number {span}"
                        + (" or None" if allow_none else ""))
    if value < low or (high is not None and value > high):
        raise ValueError(f"{name} = {value}: must be a whole number {span}")


#: Sweep points a ``Results``' text and HTML views show.
REPR_ROWS = 8


@dataclass(eq=False)
class Results:
    """The tables of a finished run, as pandas DataFrames: ``realizations`` (one row per
    realisation), ``summary`` (one row per sweep point), ``history`` (the ensemble statistics of
    time histories, None unless ``[simulation.history]`` asks for them), ``paths`` (time
    histories: every realisation's where ``run(..., paths=True)`` asked for them, in memory
    only; else those of the realisations ``[output] paths`` chooses, paths.parquet; else None),
    ``metadata`` (the provenance every result file carries),
    ``directory`` (the folder, None for a run in memory), ``events`` (the event logs of
    events.parquet, None unless ``[output] events`` asks for them) and ``poincare`` (the
    Poincare samples of poincare.parquet, None unless ``[output] poincare`` asks for them) and
    ``spectra`` (the power spectral densities of spectra.parquet, with ``[output] spectra``),
    ``rare`` (the rare-event estimates of rare.parquet, with ``[rare]``) and ``sensitivity``
    (the Sobol indices of sensitivity.parquet, with ``[sensitivity]``).
    ``scenario`` is the Study run (read from the metadata, on first use, for results read from
    a folder).

    It unpacks as ``realizations, summary = results``, as the tuple ``run`` used to return."""

    realizations: pd.DataFrame
    summary: pd.DataFrame
    history: pd.DataFrame | None = None
    paths: pd.DataFrame | None = None
    metadata: dict[str, str] = field(default_factory=dict)
    directory: Path | None = None
    study: Study | None = field(default=None, repr=False)
    events: pd.DataFrame | None = None
    poincare: pd.DataFrame | None = None
    spectra: pd.DataFrame | None = None
    rare: pd.DataFrame | None = None
    sensitivity: pd.DataFrame | None = None

    @property
    def scenario(self) -> Study:
        """The validated scenario of the run (its text as the metadata records it)."""
        if self.study is None:
            source = self.metadata.get("vines_stoch.source", "<results>")
            self.study = parse_scenario(self.metadata["vines_stoch.scenario"], source, Path(source).parent)
        return self.study

    def __iter__(self) -> Iterator[pd.DataFrame]:
        return iter((self.realizations, self.summary))

    @property
    def plot(self):
        """The report's plots into matplotlib Axes (``resultplots.ResultsPlot``):
        ``results.plot.metric("edm")``, ``.exceedance("roof")``, ``.drift_profile(point)``."""
        from .resultplots import ResultsPlot

        return ResultsPlot(self)

    def exceedance(self, metric: str, value: float) -> pd.DataFrame:
        """Per sweep point, the fraction of the realisations ended ok whose ``metric`` (a column
        of ``realizations``: ``x1_max``, ``drift_ratio_max``, ``x_max_roof``...) exceeds
        ``value``, with its 95 % Wilson interval (``metrics.exceedance``): columns ``point``, the
        swept keys, ``n``, ``p``, ``p_lo``, ``p_hi``."""
        from .metrics import exceedance
        from .signals import floor_name, floors_in

        r = self.realizations
        metric = floor_name(metric, floors_in(r.columns))
        if metric not in r.columns:
            raise KeyError(f"metric {metric!r}: not a column of the realisations table")
        swept = [c for c in self.summary.columns if "." in str(c)]
        rows = []
        for point, group in r[r["status"] == "ok"].groupby("point", sort=True):
            p, low, high = exceedance(int((group[metric] > value).sum()), len(group))
            rows.append({"point": point, **{k: group[k].iloc[0] for k in swept}, "n": len(group), "p": p,
                         "p_lo": low, "p_hi": high})
        return pd.DataFrame(rows)

    def fragility(self, limit: str, im: str, diverged: str = "exclude", samples: int = 1000,
                  seed: int = 0) -> pd.DataFrame:
        """The lognormal fragility of ``limit`` against the intensity ``im`` (a swept key, ``sa`` or
        ``pga``) fitted in memory, as ``vines-stoch fragility`` fits a folder but writing nothing:
        one row a stripe with ``median``, ``beta`` and their 95 % bootstrap bounds, and the curve
        at the stripe (``fitted``)."""
        from .fragility import fitted

        return fitted(self.realizations, self.rare, limit, im, diverged, samples, seed)[0]

    def _headline(self) -> tuple[str, pd.DataFrame]:
        """One line of what ran and where, and the summary's headline columns (``REPR_ROWS`` rows
        at most): the swept keys, the realisations ok, the mean EDM with its 95 % interval, the
        peak roof displacement and energy, each limit's exceedance and the estimate's method."""
        s = self.summary
        swept = [c for c in s.columns if "." in str(c)]
        columns = [*swept, "n_ok", "n_failed", "edm_mean", "edm_ci95_lo", "edm_ci95_hi", "x1_max_mean",
                   "e1_max_mean", *(c for c in s.columns if str(c).startswith("p_")
                                    and not str(c).endswith(("_lo", "_hi", "_estimate", "_z"))),
                   "estimate_method"]
        name = self.metadata.get("vines_stoch.name") or (self.study.name if self.study is not None else "?")
        where = f"folder {self.directory}" if self.directory is not None else "in memory"
        tables = [f"{label} {frame.shape[0]:,} x {frame.shape[1]}" for label, frame in
                  (("realizations", self.realizations), ("summary", s), ("history", self.history),
                   ("paths", self.paths), ("events", self.events), ("poincare", self.poincare),
                   ("spectra", self.spectra), ("rare", self.rare), ("sensitivity", self.sensitivity))
                  if frame is not None]
        failed = int(s["n_failed"].sum()) if "n_failed" in s else 0
        line = (f"Results of {name!r} ({where}): {len(s)} sweep point(s), {len(self.realizations):,} "
                f"realisation(s){f', {failed} failed' if failed else ''}; tables: {', '.join(tables)}")
        shown = [c for c in dict.fromkeys(columns) if c in s]
        return line, s[shown].head(REPR_ROWS)

    def __repr__(self) -> str:
        line, head = self._headline()
        hidden = len(self.summary) - REPR_ROWS
        more = f"\n... {hidden} more sweep point(s)" if hidden > 0 else ""
        with pd.option_context("display.width", 120, "display.max_columns", 12, "display.precision", 4):
            return f"{line}\n{head.to_string(index=False)}{more}"

    def _repr_html_(self) -> str:
        """The notebook's view: the line of what ran and the headline table (``_headline``)."""
        import html

        line, head = self._headline()
        hidden = len(self.summary) - REPR_ROWS
        more = f"<p>... {hidden} more sweep point(s)</p>" if hidden > 0 else ""
        return (f"<p>{html.escape(line)}</p>{head.to_html(index=False, float_format=lambda v: f'{v:.4g}')}"
                f"{more}")

    def __getitem__(self, index: int) -> pd.DataFrame:
        return (self.realizations, self.summary)[index]

    def __len__(self) -> int:
        return 2


def read_results(directory: str | Path) -> Results:
    """The results of a finished run in ``directory`` (after ``store.check_folder``: never the
    results of two runs), ``history``, ``paths``, ``events``, ``poincare``, ``spectra``, ``rare``
    and ``sensitivity`` where the run wrote them."""
    from .store import check_folder, read_metadata

    directory = Path(directory)
    check_folder(directory)
    def table(name: str) -> pd.DataFrame | None:
        path = directory / f"{name}.parquet"
        return pd.read_parquet(path) if path.is_file() else None

    return Results(table("realizations"), table("summary"), table("history"), table("paths"),
                   metadata=read_metadata(directory / "summary.parquet"), directory=directory,
                   events=table("events"), poincare=table("poincare"), spectra=table("spectra"),
                   rare=table("rare"), sensitivity=table("sensitivity"))


@dataclass(eq=False)
class Solution:
    """The time histories of one realisation (``solve``), as diffrax's ``Solution``: ``ts``
    (s), ``ys`` by signal name (``x1``, ``e1``, ``x_k``, ``drift_k``: m, J), and ``metrics``,
    the realisation's row of ``realizations.parquet`` (the same values as in an ensemble run
    of the scenario)."""

    ts: np.ndarray
    ys: dict[str, np.ndarray]
    metrics: pd.Series
    point: int
    realization: int
    scenario: Study = field(repr=False)

    def frame(self) -> pd.DataFrame:
        """The histories as a table: ``t`` and one column per signal."""
        return pd.DataFrame({"t": self.ts, **self.ys})

    def __repr__(self) -> str:
        m = self.metrics
        shown = ", ".join(f"{k} = {m[k]:.4g}" for k in ("edm", "x1_max", "e1_max") if k in m)
        span = f"[{self.ts[0]:g}, {self.ts[-1]:g}] s" if len(self.ts) else "no times"
        return (f"Solution of sweep point {self.point}, realisation {self.realization}: {len(self.ts):,} "
                f"times over {span}; signals {', '.join(self.ys)}; {shown}")
