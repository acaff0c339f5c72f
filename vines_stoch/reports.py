"""Reports of finished runs: Markdown tables (pandas) and PNG plots (matplotlib, where
installed), and the side-by-side comparison of several result directories."""

from __future__ import annotations

import math
import tomllib
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
import pandas as pd
from scipy.special import ndtr

from .fragility import stripes
from .metrics import limit_names
from .plotting import REPORT_EXTRA, counts, label, legend, pyplot
from .plotting import save as save_figure
from .results import read_results
from .scenario.settings import REGIME_SAMPLES
from .store import component, fresh, within

#: Metrics compared by default.
COMPARED = ("edm", "e1_max", "energy_integral", "impacts")
#: EDM level of the "effective range" table.
EDM_LEVEL = 0.8


@dataclass
class Run:
    """One result directory: its tables, scenario and label."""

    directory: Path
    label: str
    realizations: pd.DataFrame
    summary: pd.DataFrame
    history: pd.DataFrame | None
    scenario: dict
    seed: int
    poincare: pd.DataFrame | None = None
    spectra: pd.DataFrame | None = None
    paths: pd.DataFrame | None = None
    rare: pd.DataFrame | None = None
    sensitivity: pd.DataFrame | None = None

    @classmethod
    def read(cls, directory: str | Path, label: str | None = None) -> Run:
        directory = Path(directory)
        results = read_results(directory)  # (refuses results of two runs, fragility's too)
        meta = results.metadata
        scenario = tomllib.loads(meta["vines_stoch.scenario"])
        return cls(directory, label or scenario.get("name", directory.name), results.realizations,
                   results.summary, results.history, scenario, int(meta["vines_stoch.seed"]),
                   results.poincare, results.spectra, results.paths, results.rare, results.sensitivity)

    @property
    def swept(self) -> list[str]:
        """Swept keys (columns of the summary)."""
        return [k for k in self.scenario.get("sweep", {}) if k != "zip" and k in self.summary.columns]

    @property
    def limits(self) -> list[str]:
        """Names of the run's limits (its ``first_passage_NAME`` columns)."""
        return limit_names(self.realizations)

    def fragility(self) -> pd.DataFrame | None:
        """The fits of ``vines-stoch fragility`` in the directory (one row per limit and
        intensity), or None."""
        path = self.directory / "fragility.parquet"
        if not path.is_file():
            return None
        return pd.read_parquet(path).drop_duplicates(["limit", "im_key"]).reset_index(drop=True)

    def intensity(self, limit: str) -> str | None:
        """The intensity the exceedances of ``limit`` are shown against: that of its fragility
        fit, else the first numeric swept key."""
        fits = self.fragility()
        if fits is not None and (fits["limit"] == limit).any():
            return str(fits.loc[fits["limit"] == limit, "im_key"].iloc[0])
        return self.axes[0] if self.axes else None

    @property
    def axes(self) -> list[str]:
        """Swept keys with numeric values (a suite of record files sweeps texts)."""
        return [k for k in self.swept if pd.api.types.is_numeric_dtype(self.summary[k])]

    @property
    def common(self) -> bool:
        return bool(self.scenario.get("ensemble", {}).get("common_random_numbers", True))


def markdown(frame: pd.DataFrame, digits: int = 4) -> str:
    """A pipe table of ``frame`` (numbers to ``digits`` significant digits)."""
    def cell(v: object) -> str:
        if isinstance(v, (float, np.floating)):
            return "-" if not np.isfinite(v) else f"{v:.{digits}g}"
        return str(v)

    lines = ["| " + " | ".join(map(str, frame.columns)) + " |",
             "| " + " | ".join("---:" if frame[c].dtype.kind in "fiu" else "---" for c in frame.columns)
             + " |"]
    lines += ["| " + " | ".join(cell(v) for v in row) + " |" for row in frame.itertuples(index=False)]
    return "\n".join(lines)


def compare(runs: list[Run], metrics: tuple[str, ...] = COMPARED) -> pd.DataFrame:
    """Per sweep point and metric: each run's mean, and each later run's difference from the
    first with its standard error and 95 % interval.  Runs with the same seed and common random
    numbers are paired realisation by realisation (``scipy.stats.ttest_rel``: the Student-t
    interval of the paired differences); otherwise the errors of independent means are combined
    (a normal interval)."""
    first = runs[0]
    for run in runs[1:]:
        if len(run.summary) != len(first.summary):
            raise ValueError(f"{run.directory}: {len(run.summary)} sweep points, {first.directory}: "
                             f"{len(first.summary)}; compare runs of the same grid")
    rows = []
    for p in range(len(first.summary)):
        for m in metrics:
            row: dict[str, object] = {"point": p}
            for k in first.swept:
                row[k] = first.summary[k].iloc[p]
            row["metric"] = m
            for run in runs:
                row[run.label] = _mean_and_sem(run, p, m)[0]
            for run in runs[1:]:
                diff, se, (low, high), paired = _difference(first, run, p, m)
                row[f"{run.label} - {first.label}"] = diff
                row[f"se ({run.label})"] = se
                row[f"ci95 ({run.label})"] = f"[{low:.4g}, {high:.4g}]"
                row[f"paired ({run.label})"] = "yes" if paired else "no"
            rows.append(row)
    return pd.DataFrame(rows)


def comparable(run: Run) -> list[str]:
    """What ``compare`` can compare in ``run``: every metric column of its summary (the floors',
    drift ratios and declared metrics included) and each limit's exceedance ``p_NAME``."""
    from .metrics import metric_columns

    return [m for m in metric_columns(run.realizations) if f"{m}_mean" in run.summary] + [
        f"p_{name}" for name in run.limits]


def realization_values(frame: pd.DataFrame, metric: str) -> pd.Series:
    """A metric's value in each row of a realisations table; for a limit's ``p_NAME`` the
    indicator that the realisation exceeded it (``first_passage_NAME`` not NaN)."""
    if metric.startswith("p_") and f"first_passage_{metric[2:]}" in frame:
        return frame[f"first_passage_{metric[2:]}"].notna().astype(float)
    return frame[metric].astype(float)


def _mean_and_sem(run: Run, point: int, metric: str) -> tuple[float, float]:
    """A metric's mean at ``point`` and its standard error (a limit's ``p_NAME``: the binomial
    ``sqrt(p (1 - p) / n_ok)``)."""
    s = run.summary
    if f"{metric}_mean" in s:
        return float(s[f"{metric}_mean"].iloc[point]), float(s[f"{metric}_sem"].iloc[point])
    p, n = float(s[metric].iloc[point]), int(s["n_ok"].iloc[point])
    return p, math.sqrt(p * (1.0 - p) / n) if n else math.nan


def _difference(a: Run, b: Run, point: int,
                metric: str) -> tuple[float, float, tuple[float, float], bool]:
    """``b - a`` of ``metric``'s mean at ``point``: the difference, its standard error, its 95 %
    interval and whether the realisations were paired."""
    from scipy.stats import norm, ttest_rel
    from scipy.stats import t as student_t

    ra = a.realizations[(a.realizations["point"] == point) & (a.realizations["status"] == "ok")]
    rb = b.realizations[(b.realizations["point"] == point) & (b.realizations["status"] == "ok")]
    if a.seed == b.seed and a.common and b.common:
        left = pd.DataFrame({"realization": ra["realization"], metric: realization_values(ra, metric)})
        right = pd.DataFrame({"realization": rb["realization"], metric: realization_values(rb, metric)})
        joined = left.merge(right, on="realization")
        if len(joined) > 1:
            y, x = joined[f"{metric}_y"].to_numpy(dtype=float), joined[f"{metric}_x"].to_numpy(dtype=float)
            test = ttest_rel(y, x)
            ci = test.confidence_interval(0.95)
            se = 0.5 * (ci.high - ci.low) / student_t.ppf(0.975, test.df)  # (the interval's half-width)
            return float(np.mean(y - x)), float(se), (float(ci.low), float(ci.high)), True
    (ma, sa), (mb, sb) = _mean_and_sem(a, point, metric), _mean_and_sem(b, point, metric)
    diff = float(mb - ma)
    se = float(math.hypot(sa, sb))
    low, high = norm.interval(0.95, loc=diff, scale=se) if se > 0 else (diff, diff)
    return diff, se, (float(low), float(high)), False


def effective_range(run: Run, level: float = EDM_LEVEL) -> dict[str, object]:
    """The swept values (and mean input energies) where the mean EDM is at least ``level``,
    and where even the lower 95 % confidence bound is."""
    s = run.summary
    key = run.axes[0] if run.axes else None
    out: dict[str, object] = {"run": run.label}
    for name, mask in (("mean EDM", s["edm_mean"] >= level), ("95 % lower bound", s["edm_ci95_lo"] >= level)):
        hit = s[mask.fillna(False)]
        if hit.empty:
            out[f"{key or 'point'} where {name} >= {level}"] = "none"
            continue
        values = hit[key] if key else hit["point"]
        out[f"{key or 'point'} where {name} >= {level}"] = (f"{values.min():.4g} to {values.max():.4g} "
                                                            f"({len(hit)} of {len(s)} points)")
        if name == "mean EDM":
            out["input energy there"] = (f"{hit['input_energy_mean'].min():.4g} to "
                                         f"{hit['input_energy_mean'].max():.4g}")
    return out


def _value(v: object) -> str:
    """A swept value as written in titles: numbers to 4 significant digits, texts as they are."""
    return f"{v:.4g}" if isinstance(v, (int, float, np.number)) else str(v)


def _percent(column: str) -> str:
    """``e1_q05`` -> ``5``, ``e1_q975`` -> ``97.5``."""
    return f"{float('0.' + column.rsplit('_q', 1)[1]) * 100:g}"


def _point(run: Run, point: int | None) -> int:
    """The sweep point of the per-point plots: ``point``, or the middle one (``ValueError`` for a
    point the run does not have)."""
    if point is not None and not 0 <= point < len(run.summary):
        raise ValueError(f"--point {point}: {run.directory} has {len(run.summary)} sweep point(s), 0 to "
                         f"{len(run.summary) - 1}")
    return point if point is not None else len(run.summary) // 2


#: Rows of a path's end that its time-history plot shows (the whole path in phase portraits).
RECENT_ROWS = 1000
#: Colours of the impact zones: no impacts, one wall, both walls.
ZONE_COLORS = ("#bbbbbb", "#f0a030", "#c03030")


def phase_pairs(signals: list[str]) -> list[tuple[str, str]]:
    """The (displacement, velocity) signal pairs among ``signals``: ``x_k`` with ``v_k``,
    ``xa_j`` with ``va_j``."""
    pairs = [(f"x_{name[2:]}", name) for name in signals if name.startswith("v_")]
    pairs += [(f"xa_{name[3:]}", name) for name in signals if name.startswith("va_")]
    return [(x, v) for x, v in pairs if x in signals]

def _plots(runs: list[Run], out: Path, point: int | None) -> list[str]:
    """Write the plots, PNG and SVG (where matplotlib is installed); returns the PNG files' names."""
    plt = pyplot(f"the plots of {out / 'report.md'}")
    if plt is None:
        return []
    files = []

    def save(fig, name: str) -> None:
        legend(fig.axes[0])
        save_figure(fig, out / name)
        files.append(name)

    canvas = _Canvas(plt, runs, runs[0].scenario, point, save)
    for draw in PLOTS:
        draw(canvas)
    return files


class _Canvas(NamedTuple):
    """What every plot of a report draws with: pyplot, the runs, the first run's scenario tables
    (the units of its swept keys), the sweep point of the one-point plots, and ``save``."""

    plt: Any
    runs: list[Run]
    tables: dict
    point: int | None
    save: Callable[[Any, str], None]


def _keyed(runs: list[Run]) -> list[Run]:
    """The runs swept over one key (the plots against the swept value)."""
    return [run for run in runs if len(run.swept) == 1 and run.axes]


def _edm_against_input(canvas: _Canvas) -> None:
    """The EDM against the input energy, one line a run, with its 95 % interval."""
    plt, runs, save = canvas.plt, canvas.runs, canvas.save
    fig, ax = plt.subplots()
    for run in runs:
        s = run.summary.sort_values("input_energy_mean")
        ax.plot(s["input_energy_mean"], s["edm_mean"], "o-", ms=3, label=run.label)
        ax.fill_between(s["input_energy_mean"], s["edm_ci95_lo"], s["edm_ci95_hi"], alpha=0.25)
    ax.axhline(EDM_LEVEL, color="grey", lw=0.8, ls="--")
    ax.set(xscale="log", xlabel=label("input_energy_mean"), ylabel=f"{label('edm_mean')}, 95 % interval",
           title="Energy dissipation measure against input energy")
    save(fig, "edm_vs_input_energy.png")


def _sweep_plots(canvas: _Canvas) -> None:
    """Against a run's one swept key: the energy integral, and the maximum energy over the regimes."""
    plt, runs, tables, save = canvas.plt, canvas.runs, canvas.tables, canvas.save
    keyed = _keyed(runs)
    if keyed:
        key = keyed[0].axes[0]
        fig, ax = plt.subplots()
        for run in keyed:
            s = run.summary.sort_values(key)
            ax.plot(s[key], s["energy_integral_mean"], "o-", ms=3, label=run.label)
            ax.fill_between(s[key], s["energy_integral_ci95_lo"].clip(lower=1e-300),
                            s["energy_integral_ci95_hi"], alpha=0.25)
        ax.set(xscale="log", yscale="log", xlabel=label(key, tables), ylabel=label("energy_integral_mean"),
               title="Energy integral of the primary")
        save(fig, "energy_integral_vs_sweep.png")

        regimes = [run for run in keyed if run.realizations["regime"].notna().any()]
        if regimes:
            fig, ax = plt.subplots()
            for run in regimes:
                s = run.summary.sort_values(key)
                ax.plot(s[key], s["e1_max_mean"], "o-", ms=3, label=run.label)
            run = regimes[0]
            r = run.realizations.groupby("point")["regime"].first()
            values = run.summary.set_index("point")[key].sort_values()
            x = values.to_numpy(dtype=float)
            mid = 0.5 * (x[1:] + x[:-1])
            lows = np.r_[x[0] - (mid[0] - x[0] if x.size > 1 else 0.5), mid]
            highs = np.r_[mid, x[-1] + (x[-1] - mid[-1] if x.size > 1 else 0.5)]
            colors = plt.cm.tab10.colors
            names = list(dict.fromkeys(r.dropna()))
            for p, lo, hi in zip(values.index, lows, highs):  # each point's regime over its share of the axis
                if isinstance(r.get(p), str):
                    ax.axvspan(lo, hi, color=colors[names.index(r[p]) % 10], alpha=0.3, lw=0)
            for i, name in enumerate(names):
                ax.plot([], [], "s", color=colors[i % 10], alpha=0.5, label=f"regime {name}")
            ax.set(xlabel=label(key, tables), ylabel=label("e1_max_mean"),
                   title="Maximum primary energy with regimes")
            save(fig, "e1_max_regimes.png")


def _estimates_plot(canvas: _Canvas) -> None:
    """The Monte Carlo means beside their estimates without an ensemble, a metric a panel."""
    plt, runs, tables, save = canvas.plt, canvas.runs, canvas.tables, canvas.save
    estimated = [run for run in runs if _estimated(run)]
    if estimated:  # the Monte Carlo means and their estimates on the same axes, a metric a panel
        run = estimated[0]
        metrics = _estimated(run)
        key = run.axes[0] if len(run.swept) == 1 and run.axes else "point"
        fig, axes = plt.subplots(1, len(metrics), figsize=(4.2 * len(metrics), 3.4), squeeze=False)
        for ax, metric in zip(axes[0], metrics):
            for r in estimated:
                s = r.summary.sort_values(key)
                line = ax.errorbar(s[key], s[f"{metric}_mean"], yerr=1.96 * s[f"{metric}_sem"], fmt="o",
                                   ms=3, capsize=2, label=f"{r.label}: Monte Carlo, 95 %")
                ax.plot(s[key], s[f"{metric}_estimate"], "-", color=line[0].get_color(),
                        label=f"{r.label}: {s['estimate_method'].iloc[0]}")
            if key != "point" and (run.summary[key] > 0).all():
                ax.set_xscale("log")
            ax.set(xlabel=label(key, tables) if key != "point" else "sweep point",
                   ylabel=label(f"{metric}_mean"), title=metric)
        fig.suptitle("Estimates without an ensemble beside the Monte Carlo means")
        save(fig, "estimates.png")


def _zones_plot(canvas: _Canvas) -> None:
    """Where the absorbers meet both walls, one or none, against the swept value."""
    plt, runs, tables, save = canvas.plt, canvas.runs, canvas.tables, canvas.save
    keyed = _keyed(runs)
    walls = [run for run in keyed if (run.realizations["impacts"] > 0).any()]
    if walls:  # where the absorbers meet both walls, one or none, against the swept value
        key = walls[0].axes[0]
        fig, ax = plt.subplots()
        zones = ("no impacts", "one wall", "both walls")
        for row, run in enumerate(walls):
            ok = run.realizations[run.realizations["status"] == "ok"]
            hit = ok.groupby("point")[["impacts_left", "impacts_right"]].mean() > 0
            zone = hit.sum(axis=1)  # (walls met on average over the point's realisations)
            values = run.summary.set_index("point")[key].loc[zone.index]
            ax.scatter(values, np.full(len(zone), row), c=[ZONE_COLORS[z] for z in zone], s=40, marker="s")
        for z, name in enumerate(zones):
            ax.plot([], [], "s", color=ZONE_COLORS[z], label=name)
        swept = np.concatenate([run.summary[key].to_numpy(dtype=float) for run in walls])
        if (swept > 0).all() and swept.max() > 100.0 * swept.min():  # (values over decades)
            ax.set_xscale("log")
        ax.set(xlabel=label(key, tables), yticks=range(len(walls)), yticklabels=[run.label for run in walls],
               ylim=(-0.8, len(walls) - 0.2), title="Impact zones: walls met against the swept value")
        save(fig, "impact_zones.png")


def _path_plots(canvas: _Canvas) -> None:
    """One realisation's time histories, a signal an axis, and its phase portraits."""
    plt, runs, point, save = canvas.plt, canvas.runs, canvas.point, canvas.save
    traced = [run for run in runs if run.paths is not None and len(run.paths)]
    if traced:  # one realisation's time histories, a signal an axis, and its phase portraits
        chosen, portraits = [], []
        for run in traced:
            p = _point(run, point)
            rows = run.paths[run.paths["point"] == p]
            first = rows[rows["realization"] == rows["realization"].min()]
            where = ", ".join(f"{k} = {_value(run.summary[k].iloc[p])}" for k in run.swept) or f"point {p}"
            signals = [c for c in first.columns
                       if c not in ("point", "realization", "t") and c not in run.swept]
            chosen.append((run, where, first, signals))
            portraits += [(run, where, first, x, v) for x, v in phase_pairs(signals)]
        names = list(dict.fromkeys(signal for *_, signals in chosen for signal in signals))
        fig, axes = plt.subplots(len(names), 1, sharex=True, squeeze=False,
                                 figsize=(6.4, 1.0 + 1.3 * len(names)))
        for run, where, first, signals in chosen:
            recent = first.iloc[-RECENT_ROWS:]  # (the path's end: its steady motion, legible)
            for signal in signals:
                axes[names.index(signal), 0].plot(recent["t"], recent[signal], lw=0.8,
                                                  label=f"{run.label} ({where})")
        for ax, signal in zip(axes[:, 0], names):
            ax.set_title(label(signal), fontsize=8, loc="left")
        axes[-1, 0].set_xlabel(label("t"))
        shown = chosen[0][2]["t"].iloc[-RECENT_ROWS:]
        axes[0, 0].set_title(f"Time histories of realisation {int(chosen[0][2]['realization'].iloc[0])}, "
                             f"t = {shown.iloc[0]:g} to {shown.iloc[-1]:g} s\n{label(names[0])}", fontsize=8,
                             loc="left")
        save(fig, "paths.png")
        if portraits:
            fig, ax = plt.subplots()
            for run, where, first, x, v in portraits:
                ax.plot(first[x], first[v], lw=0.6, label=f"{run.label} ({where}): {x}")
            ax.set(xlabel=f"displacement: {', '.join(label(x) for *_, x, _ in portraits)}",
                   ylabel=f"velocity: {', '.join(label(v) for *_, v in portraits)}", title="Phase portraits")
            save(fig, "phase_portrait.png")


def _section_plots(canvas: _Canvas) -> None:
    """The roof's Poincare samples: against the swept value, and in its phase plane."""
    plt, runs, tables, point, save = canvas
    sections = [run for run in runs if run.poincare is not None and len(run.poincare)]
    if sections:  # the roof's Poincare samples: against the swept value, and in its phase plane
        roof = max(int(c[2:]) for c in sections[0].poincare.columns if c.startswith("x_") and c[2:].isdigit())
        x, v = f"x_{roof}", f"v_{roof}"
        swept = [run for run in sections if len(run.swept) == 1 and run.axes]
        if swept:
            key = swept[0].axes[0]
            fig, ax = plt.subplots()
            for run in swept:  # (the last REGIME_SAMPLES of each realisation: its steady regime)
                steady = run.poincare.groupby(["point", "realization"], sort=False).tail(REGIME_SAMPLES)
                ax.plot(steady[key], steady[x], ".", ms=2, label=run.label)
            ax.set(xlabel=label(key, tables), ylabel=f"{label(x)} at t = n T",
                   title=f"Bifurcation diagram: the roof once a forcing period (last {REGIME_SAMPLES})")
            save(fig, "bifurcation.png")
        fig, ax = plt.subplots()
        for run in sections:
            p = _point(run, point)
            rows = run.poincare[run.poincare["point"] == p]
            where = ", ".join(f"{k} = {_value(run.summary[k].iloc[p])}" for k in run.swept) or f"point {p}"
            ax.plot(rows[x], rows[v], "o", ms=3, label=f"{run.label} ({where})")
        ax.set(xlabel=label(x), ylabel=label(v), title="Poincare section of the roof (t = n T)")
        save(fig, "poincare_section.png")


def _spectra_plot(canvas: _Canvas) -> None:
    """Each signal's power spectral density at one point, with its band."""
    plt, runs, point, save = canvas.plt, canvas.runs, canvas.point, canvas.save
    spectral = [run for run in runs if run.spectra is not None and len(run.spectra)]
    if spectral:  # each signal's density at one point, with its band
        fig, ax = plt.subplots()
        for run in spectral:
            p = _point(run, point)
            rows = run.spectra[(run.spectra["point"] == p) & (run.spectra["omega"] > 0)]
            for signal, one in rows.groupby("signal", sort=False):
                line, = ax.plot(one["omega"], one["psd"], lw=1, label=f"{run.label}: {label(signal)}")
                ax.fill_between(one["omega"], one["psd_lo"].clip(lower=1e-300), one["psd_hi"],
                                color=line.get_color(), alpha=0.25)
        ax.set(xscale="log", yscale="log", xlabel="angular frequency ω [rad/s]",
               ylabel="one-sided power spectral density [(signal unit)² s/rad]",
               title="Power spectral densities (Welch), 95 % bands")
        save(fig, "spectra.png")


def _rare_plot(canvas: _Canvas) -> None:
    """Rare-event estimates: the running estimate against the paths spent; the levels."""
    plt, runs, save = canvas.plt, canvas.runs, canvas.save
    estimated = [run for run in runs if run.rare is not None and len(run.rare)]
    if estimated:  # each point's replicas: the running estimate against the paths spent; the levels
        fig, (conv, lev) = plt.subplots(1, 2, figsize=(11, 4.2))
        for run in estimated:
            for _, row in run.rare.iterrows():
                where = ", ".join(f"{k} = {_value(row[k])}" for k in run.swept) or f"point {row['point']}"
                ps = np.asarray(row["replica_p"], float)
                spent = np.cumsum(np.asarray(row["replica_paths"], float))
                m = np.arange(1, ps.size + 1)
                mean = np.cumsum(ps) / m
                sd = np.array([ps[:k].std(ddof=1) if k > 1 else np.nan for k in m])
                line, = conv.plot(spent, mean, "o-", ms=3, label=f"{run.label} ({where}): {row['method']}")
                conv.fill_between(spent, np.clip(mean - 1.96 * sd / np.sqrt(m), mean / 100, None),
                                  mean + 1.96 * sd / np.sqrt(m), color=line.get_color(), alpha=0.2)
                levels = np.asarray(row["level_values"], float)
                lev.plot(np.arange(1, levels.size + 1), levels, ".-", ms=3, color=line.get_color(),
                         label=f"{run.label} ({where})")
        conv.set(xscale="log", yscale="log", xlabel="path-equivalents spent",
                 ylabel="exceedance probability (mean of the replicas, 95 %)",
                 title="Rare-event estimates as replicas accrue")
        lev.set(xlabel="level", ylabel="level / the limit's value",
                title="Levels of a replica (splitting: z_j; subset: thresholds)")
        save(fig, "rare_events.png")


def _sensitivity_plot(canvas: _Canvas) -> None:
    """First-order and total Sobol indices at one point, with their intervals."""
    plt, runs, point, save = canvas.plt, canvas.runs, canvas.point, canvas.save
    indexed = [run for run in runs if run.sensitivity is not None and len(run.sensitivity)]
    if indexed:  # first-order and total indices at one point, with their intervals
        fig, ax = plt.subplots()
        for i, run in enumerate(indexed):
            rows = run.sensitivity[run.sensitivity["point"] == _point(run, point)]
            x = np.arange(len(rows)) + 0.4 * i / len(indexed)
            for offset, name, title in ((0.0, "s1", "first order"), (0.2, "st", "total")):
                err = np.vstack([rows[name] - rows[f"{name}_lo"], rows[f"{name}_hi"] - rows[name]]).clip(0)
                ax.bar(x + offset / len(indexed), rows[name], width=0.2 / len(indexed), yerr=err, capsize=3,
                       label=f"{run.label}: {title}")
            ax.set_xticks(np.arange(len(rows)) + 0.1, rows["parameter"], rotation=15)
        metric = indexed[0].scenario.get("sensitivity", {}).get("metric", "edm")
        ax.set(ylabel="Sobol index (bootstrap 95 %)",
               title=f"Sensitivity of {metric} to the uncertain parameters")
        save(fig, "sensitivity.png")


def _edm_histogram(canvas: _Canvas) -> None:
    """The EDM's distribution at one sweep point."""
    plt, runs, point, save = canvas.plt, canvas.runs, canvas.point, canvas.save
    fig, ax = plt.subplots()
    samples = {}
    for run in runs:
        p = _point(run, point)
        ok = run.realizations[(run.realizations["point"] == p) & (run.realizations["status"] == "ok")]
        where = ", ".join(f"{k} = {_value(run.summary[k].iloc[p])}" for k in run.swept) or f"point {p}"
        samples[f"{run.label} ({where})"] = ok["edm"].to_numpy(dtype=float)
    pooled = np.concatenate(list(samples.values()))
    edges = np.histogram_bin_edges(pooled[np.isfinite(pooled)], bins=min(40, max(5, pooled.size // 8)))
    for name, edm in samples.items():
        ax.hist(edm, bins=edges, alpha=0.5, label=name)
    ax.set(xlabel=label("edm"), ylabel="realisations", title="EDM distribution at one sweep point")
    counts(ax.yaxis)
    save(fig, "edm_histogram.png")


def _exceedance_plot(canvas: _Canvas) -> None:
    """Exceedance against intensity, with the fragility curves fitted."""
    plt, runs, tables, save = canvas.plt, canvas.runs, canvas.tables, canvas.save
    shown = [(run, limit, run.intensity(limit)) for run in runs for limit in run.limits]
    shown = [(run, limit, key, stripes(run.realizations, limit, key)) for run, limit, key in shown
             if key is not None]
    if shown:  # exceedance against intensity, with the fragility curves fitted
        fig, ax = plt.subplots()
        for run, limit, key, table in shown:
            err = np.vstack([table["fraction"] - table["fraction_lo"],
                             table["fraction_hi"] - table["fraction"]])
            bars = ax.errorbar(table["im"], table["fraction"], yerr=err, fmt="o", ms=4, capsize=3,
                               label=f"{run.label}: {limit} against {key} (95 % intervals)")
            fits = run.fragility()
            fit = None if fits is None else fits[(fits["limit"] == limit) & (fits["im_key"] == key)]
            if fit is not None and len(fit) and np.isfinite(fit["median"].iloc[0]):
                median, beta = fit["median"].iloc[0], fit["beta"].iloc[0]
                x = np.geomspace(table["im"][table["im"] > 0].min() / 2, table["im"].max() * 2, 200)
                ax.plot(x, ndtr(np.log(x / median) / beta), color=bars[0].get_color(),
                        label=f"fragility: median {median:.4g}, beta {beta:.3g}")
        if all((table["im"] > 0).all() for *_, table in shown):
            ax.set_xscale("log")
        ax.set(xlabel=", ".join(dict.fromkeys(label(key, tables) for _, _, key, _ in shown)),
               ylabel="probability of exceeding the limit", ylim=(-0.02, 1.02),
               title="Exceedance probability against intensity")
        save(fig, "exceedance.png")


def _history_plot(canvas: _Canvas) -> None:
    """The primary's energy over time: mean and quantile band."""
    plt, runs, point, save = canvas.plt, canvas.runs, canvas.point, canvas.save
    histories = [run for run in runs if run.history is not None and "e1_mean" in run.history.columns]
    if histories:
        fig, ax = plt.subplots()
        shares = all(h.history.loc[h.history["point"] == _point(h, point), "e1_mean"].iloc[0] > 0
                     for h in histories)
        for run in histories:
            h = run.history[run.history["point"] == _point(run, point)]
            scale = h["e1_mean"].iloc[0] if shares else 1.0
            quantiles = sorted(c for c in h.columns if c.startswith("e1_q"))
            line, = ax.plot(h["t"], h["e1_mean"] / scale, label=f"{run.label}: mean")
            if len(quantiles) >= 2:
                ax.fill_between(h["t"], h[quantiles[0]] / scale, h[quantiles[-1]] / scale,
                                color=line.get_color(), alpha=0.2,
                                label=f"{run.label}: {_percent(quantiles[0])} to "
                                      f"{_percent(quantiles[-1])} % quantiles")
        if shares:  # energy given at t = 0 (impulse, initial state): what is left in the primary
            ax.set(ylabel="energy of the primary / its initial value [–] (e1 / e1(0))",
                   title="Share of the initial energy left in the primary")
        else:
            ax.set(ylabel=label("e1"), title="Primary energy over time")
        ax.set(xlabel=label("t"))
        save(fig, "primary_energy_history.png")


#: The report's plots, in the order they are drawn.
PLOTS = (_edm_against_input, _sweep_plots, _estimates_plot, _zones_plot, _path_plots, _section_plots,
         _spectra_plot, _rare_plot, _sensitivity_plot, _edm_histogram, _exceedance_plot, _history_plot)


#: The metrics drawn beside their estimates (``_plots``), where a run has them.
ESTIMATED = ("x1_rms", "x1_max", "edm")


def _estimated(run: Run) -> list[str]:
    """The metrics of ``ESTIMATED`` with a finite estimate at some sweep point of ``run``."""
    s = run.summary
    return [m for m in ESTIMATED
            if f"{m}_estimate" in s and f"{m}_mean" in s and s[f"{m}_estimate"].notna().any()]


def _estimates(run: Run) -> list[str]:
    """The report's section on the estimates beside the Monte Carlo means (``rvt.table.beside``):
    each estimated metric's mean, estimate and distance in standard errors, and in words the
    metrics that lie more than ``rvt.table.APART`` standard errors away (none: none)."""
    from .rvt.table import APART, parted

    s = run.summary
    metrics = [c[:-len("_z")] for c in s.columns if c.endswith("_z")]
    if "estimate_method" not in s or not metrics:
        return []
    columns = ["point", *run.swept, "estimate_method"]
    for m in metrics:
        columns += [c for c in (f"{m}_mean" if f"{m}_mean" in s else m, f"{m}_estimate", f"{m}_z")]
    lines = parted(s)
    words = ([f"- {line}" for line in lines] if lines
             else [f"Every estimated metric lies within {APART:g} standard errors of its estimate."])
    return [f"## Estimates beside the Monte Carlo: {run.label}", "",
            "Exact linear random vibration or statistical linearisation, Rice / Vanmarcke crossings "
            "(`vines-stoch estimate`); `_z` is the Monte Carlo mean's distance from the estimate in "
            "standard errors.", "", markdown(s[columns]), "", *words, ""]


def report(directories: list[str | Path], out: str | Path = "reports", labels: list[str] | None = None,
           point: int | None = None) -> Path:
    """Write ``<out>/<name>/report.md`` and its PNG plots for one or several result
    directories (``name``: the first run's scenario name); returns the Markdown path."""
    labels = labels or [None] * len(directories)
    runs = [Run.read(d, label) for d, label in zip(directories, labels)]
    for run in runs:
        _point(run, point)  # (a point every run has, checked before anything is written)
    # (the name as one path component, and the folder inside ``out`` once links are followed)
    folder = Path(out) / component(str(runs[0].scenario.get("name", runs[0].directory.name)))
    folder.mkdir(parents=True, exist_ok=True)
    within(folder, out)
    files = _plots(runs, folder, point)
    parts = [f"# Report: {', '.join(run.label for run in runs)}", ""]
    for run in runs:
        s = run.summary
        table = s[["point", *run.swept, "n_ok", "n_failed", "input_energy_mean", "edm_mean", "edm_ci95_lo",
                   "edm_ci95_hi", "e1_max_mean", "energy_integral_mean", "impacts_mean"]]
        notes = [f"- point {int(p)}: {note}" for p, note in zip(s["point"], s.get("notes", [""] * len(s)))
                 if note]
        why = ["Why some statistics are undefined (NaN) or in doubt:", "", *notes, ""] if notes else []
        parts += [f"## {run.label}", "", f"Directory `{run.directory}`, seed {run.seed}, "
                  f"{int(s['n_ok'].sum() + s['n_failed'].sum())} realisations.", "", markdown(table), "",
                  *why]
    parts += [f"## Where mean EDM >= {EDM_LEVEL}", "",
              markdown(pd.DataFrame([effective_range(r) for r in runs])), ""]
    for run in runs:
        if run.limits:
            columns = [c for name in run.limits for c in (f"p_{name}", f"p_{name}_lo", f"p_{name}_hi")]
            parts += [f"## Exceedance probabilities: {run.label}", "",
                      "Fraction of the ok realisations whose peak exceeded each limit, with its 95 % Wilson "
                      "interval.", "",
                      markdown(run.summary[["point", *run.swept, "n_ok", *columns]]), ""]
        parts += _estimates(run)
        fits = run.fragility()
        if fits is not None:
            parts += [f"## Fragility: {run.label}", "",
                      "Lognormal fragility `Phi(ln(IM / median) / beta)` by maximum likelihood over the "
                      "stripes, 95 % bootstrap bounds (`vines-stoch fragility`).", "",
                      markdown(fits[["limit", "im_key", "median", "median_lo", "median_hi", "beta", "beta_lo",
                                     "beta_hi", "bootstrap_fitted", "diverged", "notes"]]), ""]
        if run.rare is not None:
            limit = run.rare["limit"].iloc[0]
            shown = ["point", *run.swept, "p", "cov", "p_lo", "p_hi", "paths", "replicas"]
            parts += [f"## Rare events: {run.label}", "",
                      f"P({limit} exceeded) by {run.rare['method'].iloc[0]} (`[rare]`), the coefficient of "
                      "variation from the replicas' spread, a 95 % interval, the path-equivalents spent.", "",
                      markdown(run.rare[shown]), ""]
        if run.sensitivity is not None:
            metric = run.scenario.get("sensitivity", {}).get("metric", "edm")
            parts += [f"## Sobol indices: {run.label}", "",
                      f"First-order and total indices of {metric} over the uncertain parameters "
                      "(`[sensitivity]`), bootstrap 95 % intervals.", "",
                      markdown(run.sensitivity.drop(columns=["point"])), ""]
    if len(runs) > 1:
        try:
            table = markdown(compare(runs))
        except ValueError as exc:
            table = f"Not compared: {exc}."
        parts += ["## Comparison (later runs minus the first)", "", table, ""]
    plots = ([f"![{f}]({f}) ([SVG]({Path(f).with_suffix('.svg')}))" for f in files] if files
             else [f"Not drawn: matplotlib is not installed; `{REPORT_EXTRA}` adds them."])
    parts += ["## Plots", ""] + plots + [""]
    path = fresh(folder / "report.md")
    path.write_text("\n".join(parts))
    return path

