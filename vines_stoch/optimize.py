"""Robust design (``vines-stoch optimize``): tune absorber parameters within bounds so that the
mean of a metric over a scenario's realisations and sweep points is best.

Every candidate runs the same ensemble: with the scenario's seed and common random numbers,
realisation ``r`` sees the same noise and the same uncertain-parameter draws at every candidate,
so the sampled objective is a deterministic, smooth-as-the-physics function of the parameters
and the optimiser is not misled by Monte Carlo noise.  A candidate that is not a valid scenario
(a rule between fields breaks: a 'from-primary' obstacle's offset < gap, ``dt`` past the
stability limit of a stiffer design) is infeasible: the search sees an infinite objective there
(an extreme barrier), and the candidate is recorded but never run and never the optimum.  The
search works in coordinates scaled to ``[0, 1]`` per parameter (on the logarithm for
``scale = "log"``) with scipy.optimize's bounded Nelder-Mead or Powell methods.
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from .ensemble import run, sample
from .plotting import REPORT_EXTRA, pyplot
from .reports import markdown
from .scenario import Bound, Optimize, ScenarioError, Study, parse_scenario, set_path
from .store import write_table

#: Side of the starting simplex, in scaled coordinates (a fifth of each range).
SIMPLEX_STEP = 0.2


@dataclass
class Optimum:
    """Outcome of an optimisation: best parameters, the objective there, every evaluation."""

    values: dict[str, float]
    objective: float
    sem: float
    history: pd.DataFrame
    message: str


def to_unit(bound: Bound, value: float) -> float:
    """Scaled coordinate of ``value`` in ``[0, 1]``."""
    if bound.scale == "log":
        return math.log(value / bound.low) / math.log(bound.high / bound.low)
    return (value - bound.low) / (bound.high - bound.low)


def from_unit(bound: Bound, u: float) -> float:
    """Parameter value at scaled coordinate ``u`` (clipped to the bounds)."""
    u = min(max(float(u), 0.0), 1.0)
    if bound.scale == "log":
        return bound.low * (bound.high / bound.low) ** u
    return bound.low + u * (bound.high - bound.low)


def objective(frame: pd.DataFrame, metric: str) -> tuple[float, float, int]:
    """Mean over sweep points of the mean of ``metric`` over the realisations that finished,
    its standard error, and the number of failed realisations."""
    ok = frame[frame["status"] == "ok"]
    groups = ok.groupby("point")[metric]
    means, sems = groups.mean(), groups.sem(ddof=1).fillna(0.0)
    points = frame["point"].nunique()
    value = float(means.mean()) if len(means) == points else math.nan
    return value, float(np.sqrt((sems ** 2).sum()) / points), int((frame["status"] != "ok").sum())


def feasible(history: pd.DataFrame) -> pd.Series:
    """Rows of an optimisation history that were run, with no failed realisation: the
    candidates that may be the optimum."""
    infeasible = history["infeasible"] if "infeasible" in history else pd.Series("", history.index)
    return (history["n_failed"] == 0) & (infeasible == "")


def optimize(study: Study, directory: Path, workers: int | None = None,
             echo: Callable[[str], None] = lambda line: None) -> Optimum:
    """Search ``study.base.optimize.parameters`` for the best objective; every evaluation is
    appended to ``directory/optimization.parquet`` as it finishes (an interrupted search keeps
    its history).  Candidates with failed (diverged) realisations are rejected; candidates that
    are not a valid scenario are infeasible (column ``infeasible``: the rule they break) and
    are not run."""
    spec: Optimize = study.base.optimize
    keys = list(spec.parameters)
    bounds = [spec.parameters[k] for k in keys]
    directory.mkdir(parents=True, exist_ok=True)
    rows: list[dict] = []
    seen: dict[tuple[float, ...], float] = {}

    def evaluate(u: np.ndarray) -> float:
        values = {k: from_unit(b, x) for k, b, x in zip(keys, bounds, u)}
        key = tuple(values.values())
        if key in seen:
            return seen[key]
        shown = ", ".join(f"{k} = {v:.6g}" for k, v in values.items())
        try:
            candidate = study.with_values(values)
        except ScenarioError as exc:  # a rule between fields breaks: never run
            rule = str(exc).split("\n")[0].removeprefix(f"{study.source}: ")
            rows.append({"evaluation": len(rows), **values, spec.objective: math.nan, "sem": math.nan,
                         "n_failed": 0, "infeasible": rule})
            write_table(pd.DataFrame(rows), directory / "optimization.parquet")
            echo(f"{len(rows):4d}  {shown}  infeasible: {rule}")
            seen[key] = math.inf
            return seen[key]
        value, sem, failed = objective(sample(candidate, workers), spec.objective)
        rows.append({"evaluation": len(rows), **values, spec.objective: value, "sem": sem,
                     "n_failed": failed, "infeasible": ""})
        write_table(pd.DataFrame(rows), directory / "optimization.parquet")
        echo(f"{len(rows):4d}  {shown}  {spec.objective} = {value:.6g} +- {sem:.2g}"
             + (f"  ({failed} failed: rejected)" if failed else ""))
        seen[key] = spec.sign * value if failed == 0 and math.isfinite(value) else math.inf
        return seen[key]

    from scipy.optimize import minimize

    u0 = np.array([to_unit(b, b.initial) for b in bounds])
    f0 = evaluate(u0)
    if rows[0]["infeasible"]:  # (the scenario's validation refuses such a start first)
        raise ValueError(f"{study.source}: optimize.parameters: the starting point "
                         f"{dict(zip(keys, (b.initial for b in bounds)))} is not a valid design: "
                         f"{rows[0]['infeasible']}; set each parameter's start (within [low, high]) "
                         "where the design is valid")
    if not math.isfinite(f0):
        raise ValueError(f"{study.source}: optimize.parameters: the starting point "
                         f"{dict(zip(keys, (b.initial for b in bounds)))} has failed (diverged) "
                         "realisations; set each parameter's start (within [low, high]) where the scene "
                         "is stable")
    options: dict = {"maxfev": spec.max_evaluations}
    if spec.method == "nelder-mead":
        simplex = [u0] + [u0 + np.eye(len(u0))[i] * (SIMPLEX_STEP if u0[i] <= 0.5 else -SIMPLEX_STEP)
                          for i in range(len(u0))]
        options.update(initial_simplex=np.array(simplex), xatol=spec.tolerance,
                       fatol=spec.tolerance * abs(f0))
    else:
        options.update(xtol=spec.tolerance, ftol=spec.tolerance)
    result = minimize(evaluate, u0, method="Nelder-Mead" if spec.method == "nelder-mead" else "Powell",
                      bounds=[(0.0, 1.0)] * len(u0), options=options)
    history = pd.DataFrame(rows)
    good = history[feasible(history)]
    best = good.loc[(spec.sign * good[spec.objective]).idxmin()]
    return Optimum({k: float(best[k]) for k in keys}, float(best[spec.objective]), float(best["sem"]),
                   history, str(result.message))


def optimum_text(study: Study, values: dict[str, float], directory: Path) -> str:
    """The scenario file with the optimum filled in, its ``[optimize]`` table removed and its
    output sent to ``directory`` (comments and layout kept)."""
    import tomlkit

    doc = tomlkit.parse(study.text)  # tables are dicts and arrays of tables lists: set_path walks them
    for key, value in values.items():
        set_path(doc, key, value)
    doc.remove("optimize")
    def moved(file: str) -> str:  # record files: found relative to the new file's folder
        return os.path.relpath(study.directory / file, directory)

    for load in doc.get("loads", []):
        if "file" in load:
            load["file"] = moved(load["file"])
    for key, values in doc.get("sweep", {}).items():
        if re.fullmatch(r"loads\.\d+\.file", key) and isinstance(values, list):  # a suite of records
            doc["sweep"][key] = [moved(v) for v in values]
    if "output" not in doc:
        doc["output"] = tomlkit.table()
    doc["output"]["directory"] = str(directory)
    header = f"# Optimum found by `vines-stoch optimize {study.source}`.\n"
    return header + tomlkit.dumps(doc)


def write_report(study: Study, best: Optimum, summary: pd.DataFrame, directory: Path) -> Path:
    """``directory/report.md`` and ``objective_history.png`` (where matplotlib is installed)."""
    spec = study.base.optimize
    metric = spec.objective
    history = best.history
    plt = pyplot(str(directory / "objective_history.png"))
    if plt is not None:
        fig, ax = plt.subplots(figsize=(6.4, 3.6))
        ok = feasible(history)
        ax.errorbar(history["evaluation"][ok], history[metric][ok], yerr=1.96 * history["sem"][ok], fmt=".",
                    color="0.6", ecolor="0.8", label="candidate (95 % interval)")
        running = (spec.sign * history[metric].where(ok, math.inf)).cummin() * spec.sign
        ax.plot(history["evaluation"], running, color="C0", label="best so far")
        ax.set_xlabel("evaluation")
        ax.set_ylabel(f"mean {metric}")
        ax.legend()
        fig.tight_layout()
        fig.savefig(directory / "objective_history.png", dpi=120)
        plt.close(fig)
    figure = ("![objective history](objective_history.png)" if plt is not None else
              f"(The plot is not drawn: matplotlib is not installed; `{REPORT_EXTRA}` adds it.)")

    table = pd.DataFrame([{"parameter": k, "low": b.low, "high": b.high, "start": b.initial, "scale": b.scale,
                           "optimum": best.values[k]} for k, b in spec.parameters.items()])
    swept = study.sweep_keys
    columns = swept + ["n_ok", "n_failed", f"{metric}_mean", f"{metric}_ci95_lo", f"{metric}_ci95_hi"]
    goal = "maximise" if spec.sign < 0 else "minimise"
    skipped = int((history["infeasible"] != "").sum()) if "infeasible" in history else 0
    evaluations = f"{len(history)} evaluations" + (f", {skipped} of them infeasible (not run)"
                                                   if skipped else "")
    text = "\n".join([
        f"# Optimisation of {study.name}", "",
        f"Scenario `{study.source}`: {goal} the mean `{metric}` over {study.base.ensemble.realizations} "
        f"realisation(s) and {len(study.points)} sweep point(s) (seed {study.base.ensemble.seed}, common "
        f"random numbers), {spec.method}, {evaluations} ({best.message}).", "",
        "## Optimum", "", markdown(table), "",
        f"Objective at the optimum: {best.objective:.6g} (standard error {best.sem:.2g}). Candidates share "
        "their random numbers, so differences between them are far more precise than this error.", "",
        "## Summary at the optimum", "", markdown(summary[columns]), "",
        "## Objective history", "", figure, "",
        markdown(history), "",
    ])
    path = directory / "report.md"
    path.write_text(text)
    return path


def optimize_scenario(study: Study, directory: Path, workers: int | None = None, progress: bool = False,
                      echo: Callable[[str], None] = lambda line: None) -> tuple[Optimum, Path]:
    """Optimise, then run the optimum as a normal scenario into ``directory`` (realisations,
    summary) next to ``optimum.toml``, ``optimization.parquet`` and ``report.md``."""
    if study.base.optimize is None:
        raise ValueError(f"{study.source}: no [optimize] table (see docs/guide/studies.md, 'Robust design')")
    best = optimize(study, directory, workers, echo)
    text = optimum_text(study, best.values, directory)
    (directory / "optimum.toml").write_text(text)
    final = parse_scenario(text, str(directory / "optimum.toml"), directory)
    _, summary = run(final, directory, workers=workers, progress=progress)
    return best, write_report(study, best, summary, directory)
