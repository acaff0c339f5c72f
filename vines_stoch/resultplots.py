"""``Results.plot``: the report's plots drawn from a results object into a matplotlib Axes, on
whatever backend the user's session has (a notebook's inline one included), each returning its
Axes (``ax``: draw into that one instead of a new figure)."""

from __future__ import annotations

from typing import Any

import numpy as np

from .plotting import REPORT_EXTRA, label
from .signals import floor_name, floors_in


class ResultsPlot:
    """The plots of one ``Results`` (``results.plot.metric("edm")``, ``.exceedance("roof")``,
    ``.drift_profile()``)."""

    def __init__(self, results: Any):
        self._results = results

    @staticmethod
    def _axes(ax: Any) -> Any:
        if ax is not None:
            return ax
        try:
            import matplotlib.pyplot as plt
        except ImportError:
            raise ImportError(f"Results.plot needs matplotlib: {REPORT_EXTRA}") from None
        return plt.subplots()[1]

    def _x(self) -> tuple[str, np.ndarray, str]:
        """The summary's x axis: its one swept key, else the sweep point's index."""
        s = self._results.summary
        swept = [c for c in s.columns if "." in str(c)]
        key = swept[0] if len(swept) == 1 else "point"
        scenario = None if self._results.study is None else self._results.study.data
        return key, s[key].to_numpy(dtype=float), label(key, scenario) if key != "point" else "sweep point"

    def metric(self, name: str = "edm", ax: Any = None) -> Any:
        """A metric's mean against the swept value with its 95 % interval (and, where the summary
        has one, its estimate without an ensemble: ``name_estimate``)."""
        ax = self._axes(ax)
        s = self._results.summary
        name = floor_name(name, floors_in(self._results.realizations.columns))
        if f"{name}_mean" not in s:
            raise KeyError(f"metric {name!r}: the summary has no {name}_mean")
        _, x, xlabel = self._x()
        order = np.argsort(x)
        ax.plot(x[order], s[f"{name}_mean"].to_numpy()[order], "o-", ms=3, label="Monte Carlo mean")
        low, high = (s[f"{name}_ci95_{end}"].to_numpy()[order] for end in ("lo", "hi"))
        ax.fill_between(x[order], low, high, alpha=0.25, label="95 % interval")
        if f"{name}_estimate" in s and s[f"{name}_estimate"].notna().any():
            ax.plot(x[order], s[f"{name}_estimate"].to_numpy()[order], "--", label="estimate")
        _log_if_decades(ax, x)
        ax.set(xlabel=xlabel, ylabel=label(f"{name}_mean"))
        ax.legend()
        return ax

    def exceedance(self, limit: str, ax: Any = None) -> Any:
        """A limit's exceedance probability against the swept value with its 95 % Wilson interval."""
        ax = self._axes(ax)
        s = self._results.summary
        _, x, xlabel = self._x()
        order = np.argsort(x)
        p, low, high = (s[f"p_{limit}{end}"].to_numpy()[order] for end in ("", "_lo", "_hi"))
        ax.errorbar(x[order], p, yerr=[p - low, high - p], fmt="o-", ms=3, capsize=2)
        _log_if_decades(ax, x)
        ax.set(xlabel=xlabel, ylabel=f"P({limit} exceeded)", ylim=(-0.02, 1.02))
        return ax

    def drift_profile(self, point: int = 0, ax: Any = None) -> Any:
        """The mean peak inter-storey drift (the drift ratio where the primary has storey heights)
        of each storey at sweep point ``point``, with its 95 % interval, storeys up the axis."""
        ax = self._axes(ax)
        s = self._results.summary
        n = sum(1 for c in s.columns if str(c).startswith("drift_max_") and str(c).endswith("_mean"))
        stem = "drift_ratio_max" if "drift_ratio_max_1_mean" in s else "drift_max"
        storeys = np.arange(1, n + 1)
        row = s.iloc[point]
        mean = np.array([row[f"{stem}_{k}_mean"] for k in storeys])
        low = np.array([row[f"{stem}_{k}_ci95_lo"] for k in storeys])
        high = np.array([row[f"{stem}_{k}_ci95_hi"] for k in storeys])
        ax.plot(mean, storeys, "o-")
        ax.fill_betweenx(storeys, low, high, alpha=0.25)
        ax.set(xlabel=("mean peak drift ratio" if stem == "drift_ratio_max" else "mean peak drift [m]"),
               ylabel="storey", yticks=storeys, title=f"Drift profile, sweep point {point}")
        return ax


    def scalogram(self, signal: str = "x1", point: int = 0, realization: int | None = None,
                  omega: np.ndarray | None = None, ax: Any = None) -> Any:
        """The wavelet scalogram (``psd.scalogram``: local amplitude against time and frequency)
        of a kept path's ``signal`` (``paths=True`` or ``[output] paths``) at sweep point
        ``point``, realisation ``realization`` (default: the first kept); ``omega``: the angular
        frequencies (rad/s; default 120 from four cycles a record to a tenth of the sampling
        rate, evenly on a log scale)."""
        from .psd import scalogram

        paths = self._results.paths
        if paths is None or signal not in paths:
            raise KeyError(f"scalogram: no kept path of {signal!r} (run with paths=True or [output] paths)")
        rows = paths[paths["point"] == point]
        kept = rows["realization"].iloc[0] if realization is None else realization
        rows = rows[rows["realization"] == kept]
        t, x = rows["t"].to_numpy(), rows[signal].to_numpy()
        dt = float(t[1] - t[0])
        if omega is None:
            omega = np.geomspace(8.0 * np.pi / (t[-1] - t[0]), 0.2 * np.pi / dt, 120)
        ax = self._axes(ax)
        mesh = ax.pcolormesh(t, omega, scalogram(x, dt, omega), shading="auto")
        ax.figure.colorbar(mesh, ax=ax, label=f"local amplitude of {signal}")
        ax.set(yscale="log", xlabel="time [s]", ylabel="angular frequency [rad/s]",
               title=f"Scalogram of {signal}, sweep point {point}")
        return ax


def _log_if_decades(ax: Any, x: np.ndarray) -> None:
    """A logarithmic x axis where the swept values are positive and span two decades or more."""
    if x.size and (x > 0).all() and x.max() >= 100.0 * x.min():
        ax.set_xscale("log")
