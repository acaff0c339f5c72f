"""matplotlib, where installed, and the one style of every plot: the plots of reports, fits and
optimisations are an extra (``pip install "vines-stoch[report]"``); without it everything else
is still written.

Units: the program never converts units; a scenario's numbers are in one consistent set, SI by
default (m, kg, s, N, J, rad/s), and the axes name each quantity with its SI unit (``label``).
A nondimensional scenario (as in Wei et al.) reads those units as its own.  Every figure is
written twice (``save``): PNG for the eye, SVG for a paper.
"""

from __future__ import annotations

import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Any

#: What adds the plots.
REPORT_EXTRA = 'pip install "vines-stoch[report]"'
#: The files ``save`` writes of a figure, by suffix: raster and vector.
FORMATS = (".png", ".svg")
#: Resolution of the PNG files.
DPI = 200
#: The one style of every plot (matplotlib ``rcParams``).
STYLE = {
    "figure.figsize": (6.4, 4.2), "font.size": 9, "axes.titlesize": 10, "axes.labelsize": 9,
    "legend.fontsize": 8, "legend.framealpha": 0.85, "axes.grid": True, "grid.alpha": 0.3,
    "axes.spines.top": False, "axes.spines.right": False, "lines.markersize": 4,
    "svg.fonttype": "none", "savefig.bbox": "tight",
}

#: Longest legend entry (characters) kept inside the axes (``legend``).
LEGEND_TEXT = 45

#: Result columns: physical name and SI unit ("" for a pure number, "count" for counts).
QUANTITIES: dict[str, tuple[str, str]] = {
    "t": ("time", "s"), "x1": ("roof displacement", "m"), "e1": ("energy of the primary", "J"),
    "edm": ("energy dissipation measure EDM", ""), "e1_max": ("peak energy of the primary", "J"),
    "energy_integral": ("energy integral of the primary", "J s"), "input_energy": ("input energy", "J"),
    "x1_max": ("peak roof displacement", "m"), "x1_rms": ("r.m.s. roof displacement", "m"),
    "impacts": ("number of impacts", "count"), "energy_residual": ("energy balance residual", ""),
    "energy_share": ("energy share of the absorbers", ""), "sa": ("spectral acceleration Sa", "m/s²"),
    "pga": ("peak ground acceleration", "m/s²"), "envelope_frequency": ("envelope frequency", "rad/s"),
    "lyapunov": ("largest Lyapunov exponent", "1/s"), "settling_time": ("settling time", "s"),
    "share": ("energy share of the absorbers", ""),
    "drift_ratio_max": ("peak inter-storey drift ratio (largest storey)", ""),
}
#: Per-floor columns (``NAME_k``): name and unit.
FLOOR_QUANTITIES = {"x": ("displacement of floor {k}", "m"), "drift": ("drift of storey {k}", "m"),
                    "v": ("velocity of floor {k}", "m/s"), "xa": ("displacement of absorber {k}", "m"),
                    "va": ("velocity of absorber {k}", "m/s"), "stroke": ("stroke of absorber {k}", "m"),
                    "contact": ("contact force of absorber {k} on its host", "N"),
                    "x_max": ("peak displacement of floor {k}", "m"),
                    "x_rms": ("r.m.s. displacement of floor {k}", "m"),
                    "drift_max": ("peak drift of storey {k}", "m"),
                    "drift_ratio_max": ("peak drift ratio of storey {k}", ""),
                    "acc_max": ("peak acceleration of floor {k}", "m/s²")}
#: Scenario fields (the last part of a dotted key): name and unit.
FIELDS = {
    "mass": ("mass", "kg"), "stiffness": ("stiffness", "N/m"), "damping": ("damping", "N s/m"),
    "clearance": ("clearance", "m"), "restitution": ("restitution", ""), "velocity": ("velocity", "m/s"),
    "displacement": ("displacement", "m"), "amplitude": ("amplitude", "N"),
    "frequency": ("frequency", "rad/s"), "phase": ("phase", "rad"), "duration": ("duration", "s"),
    "start": ("start", "s"), "width": ("width", "s"), "period": ("period", "s"), "scale": ("scale", ""),
    "dt": ("time step", "s"),
    "intensity": ("noise intensity", r"N s$^{1/2}$"), "value": ("target", "m/s²"),
}
#: Fields whose unit depends on the table they are in (load or absorber type).
_BY_TYPE = {("cubic", "stiffness"): "N/m³", ("ground-motion", "intensity"): r"m s$^{-3/2}$",
            ("filtered-noise", "damping"): "", ("ground-motion", "damping"): "",
            ("base-harmonic", "amplitude"): "m/s²"}


def label(column: str, scenario: Mapping[str, Any] | None = None) -> str:
    """An axis label for a result column or a swept key: its physical name and SI unit, then the
    column's own name (not for ``t``), e.g. ``peak energy of the primary [J] (e1_max)``; a statistic's suffix
    (``_mean``, ``_q05``) names the statistic.  ``scenario`` (the file's tables) tells the units
    that depend on a load's or an absorber's type.  A column without a known unit is its name."""
    base, statistic = column, ""
    for suffix, words in _STATISTICS.items():
        if column.endswith(suffix) and _quantity(column[:-len(suffix)]) is not None:
            base, statistic = column[:-len(suffix)], words
    found = _quantity(base)
    if found is None and "." in base:
        found = _field(base, scenario)
    if found is None:
        return column
    name, unit = found
    name = f"{name}, {statistic}" if statistic else name
    shown = "" if unit == "count" else f" [{unit or '–'}]"
    return f"{name}{shown}" + ("" if column == "t" else f" ({column})")


#: A summary column's statistic suffix and its words.
_STATISTICS = {"_mean": "mean", "_std": "std", "_sem": "std. error", "_q05": "5 % quantile", "_q50": "median",
               "_q95": "95 % quantile"}


def _quantity(column: str) -> tuple[str, str] | None:
    """Name and unit of a metric column (``QUANTITIES``, a floor's ``NAME_k``, a first passage)."""
    found = QUANTITIES.get(column)
    if found is None and "_" in column and column.rsplit("_", 1)[1].isdigit():
        kind, k = column.rsplit("_", 1)
        if kind in FLOOR_QUANTITIES:
            name, unit = FLOOR_QUANTITIES[kind]
            found = (name.format(k=k), unit)
    if found is None and column.startswith("first_passage_"):
        found = (f"first passage of {column.removeprefix('first_passage_')}", "s")
    return found


def _field(key: str, scenario: Mapping[str, Any] | None) -> tuple[str, str] | None:
    """Name and unit of a dotted scenario key (``loads.0.intensity``, ``loads.0.sa.value``)."""
    parts = key.split(".")
    found = FIELDS.get(parts[-1])
    if found is None:
        return None
    name, unit = found
    table = None
    if scenario is not None and len(parts) >= 3 and parts[1].isdigit():
        rows = scenario.get(parts[0])
        if isinstance(rows, list) and int(parts[1]) < len(rows) and isinstance(rows[int(parts[1])], Mapping):
            table = rows[int(parts[1])].get("type")
            if parts[-2] == "sa" and rows[int(parts[1])].get("units") == "g":
                unit = "g"
    unit = _BY_TYPE.get((table, parts[-1]), unit)
    if parts[-2] == "sa":
        name = "target spectral acceleration Sa"
    owner = {"loads": "load", "absorbers": "absorber"}.get(parts[0], parts[0])
    where = f"{owner} {int(parts[1]) + 1}" if len(parts) >= 3 and parts[1].isdigit() else owner
    return f"{where} {name}", unit


def available() -> bool:
    """True when matplotlib can be imported."""
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        return False
    return True


def pyplot(what: str) -> Any | None:
    """``matplotlib.pyplot`` on the file-only Agg backend with the style ``STYLE``, or None after
    one line on standard error saying that ``what`` (e.g. ``"objective_history.png"``) was not
    drawn."""
    try:
        import matplotlib
    except ImportError:
        print(f"note: {what}: not drawn, matplotlib is not installed ({REPORT_EXTRA} adds it)",
              file=sys.stderr)
        return None
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    plt.rcParams.update(STYLE)
    return plt


def counts(axis: Any) -> None:
    """Whole-number ticks on an axis of counts (``ax.yaxis``)."""
    from matplotlib.ticker import MaxNLocator

    axis.set_major_locator(MaxNLocator(integer=True))


def legend(ax: Any) -> None:
    """The legend where it hides the least data (``loc="best"``) when it is small; with more than
    three entries, or an entry longer than ``LEGEND_TEXT`` characters, below the axes instead,
    where it cannot cover the data."""
    handles, labels = ax.get_legend_handles_labels()
    if len(handles) > 3 or max(map(len, labels), default=0) > LEGEND_TEXT:
        ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.14), borderaxespad=0.0)
    else:
        ax.legend(loc="best")


def save(fig: Any, path: str | Path, metadata: Mapping[str, str] | None = None) -> list[Path]:
    """Write ``fig`` as PNG (``DPI``) and SVG beside each other (``path`` with either suffix, or
    none) and close it; ``metadata``: text entries of the PNG, and of the SVG its identifier
    (``key value`` lines; no date, so that a figure drawn again is the same file).  Returns the
    paths written."""
    import matplotlib.pyplot as plt

    from .store import fresh

    stem = Path(path).with_suffix("")
    written = []
    for suffix in FORMATS:
        target = fresh(stem.with_name(stem.name + suffix))  # (never through a link planted there)
        if suffix == ".png":
            fig.savefig(target, dpi=DPI, metadata=dict(metadata or {}))
        else:
            text = "\n".join(f"{k} {v}" for k, v in (metadata or {}).items())
            fig.savefig(target, metadata={"Date": None, **({"Identifier": text} if text else {})})
        written.append(target)
    plt.close(fig)
    return written
