"""Sobol sensitivity indices of a metric with respect to the uncertain parameters
(``[sensitivity]``, sensitivity.parquet).

The design and the estimators are SALib's (Herman and Usher, J. Open Source Softw. 2 (2017)
97): a scrambled Sobol sequence in Saltelli's scheme (Saltelli et al., Comput. Phys. Commun. 181
(2010) 259: ``N (d + 2)`` points for ``d`` parameters), first-order indices by Saltelli's
estimator, total indices by Jansen's, and their 95 % intervals by bootstrap over the base
points.

The design lives in the unit cube: each coordinate is a parameter's probability (a uniform
draw, or a standard normal draw ``Phi^-1(u)`` for the normal and lognormal laws), mapped to its
value by the law itself (``scenario.distributions``).  The map is one to one, so the indices
with respect to the cube are the parameters' own.

A simulator with intrinsic noise has no single output per parameter set.  Each design point
runs the same ``R`` realisations of the noise (realisations ``0 .. R - 1`` of the ensemble's
streams: common random numbers), and its output is the mean of the metric over them (or the
fraction exceeding a limit).  The indices are those of that conditional mean
``E[metric | parameters]`` (estimated with ``R`` paths): the noise's own variance is left out
of the decomposition, and a parameter that does not change any path gets exactly the same output
at every design point that differs only in it.
"""

from __future__ import annotations

import sys
from collections.abc import Callable

import numpy as np
import pandas as pd

#: Design points between two saves of their outputs (and two progress lines).
SAVE_EVERY = 64


def sobol_indices(model: Callable[[np.ndarray], np.ndarray], d: int, samples: int, seed: int,
                  bootstrap: int = 1000, names: list[str] | None = None) -> pd.DataFrame:
    """First-order and total Sobol indices of ``model`` (rows of points of the unit cube
    ``[0, 1]^d`` to outputs) from a Saltelli design of ``samples`` base points, with bootstrap
    95 % intervals: one row a parameter (``parameter``, ``s1``, ``s1_lo``, ``s1_hi``, ``st``,
    ``st_lo``, ``st_hi``)."""
    from SALib.analyze import sobol as analyze
    from SALib.sample import sobol as sample

    names = names or [f"x{i + 1}" for i in range(d)]
    problem = {"num_vars": d, "names": names, "bounds": [[0.0, 1.0]] * d}
    design = sample.sample(problem, samples, calc_second_order=False, scramble=True, seed=seed)
    y = np.asarray(model(design), dtype=float)

    if np.ptp(y) == 0.0:  # (no variance to apportion: every index is 0)
        zeros = np.zeros(d)
        return pd.DataFrame({"parameter": names, "s1": zeros, "s1_lo": zeros, "s1_hi": zeros,
                             "st": zeros, "st_lo": zeros, "st_hi": zeros})
    si = analyze.analyze(problem, y, calc_second_order=False, num_resamples=bootstrap, conf_level=0.95,
                         seed=seed)
    return pd.DataFrame({"parameter": names, "s1": si["S1"], "s1_lo": si["S1"] - si["S1_conf"],
                         "s1_hi": si["S1"] + si["S1_conf"], "st": si["ST"], "st_lo": si["ST"] - si["ST_conf"],
                         "st_hi": si["ST"] + si["ST_conf"]})


def parameter_values(dists: dict, unit: np.ndarray) -> dict[str, np.ndarray]:
    """The uncertain parameters' values at points of the unit cube (one column a parameter, in
    file order): each law's value of its draw (``u``, or ``Phi^-1(u)`` for the laws drawn from
    a standard normal)."""
    from scipy import stats  # (scipy.stats takes about 0.5 s to import: only where used)

    u = np.clip(unit, 1e-12, 1.0 - 1e-12)
    return {key: np.asarray(dist.value(stats.norm.ppf(u[:, k]) if dist.normal else u[:, k]), dtype=float)
            for k, (key, dist) in enumerate(dists.items())}


def table(study, outputs: Callable[[int, dict[str, float]], float], progress: bool = False,
          saved=None) -> pd.DataFrame:
    """sensitivity.parquet: one row per sweep point and uncertain parameter (the point, its
    swept values, ``sobol_indices``' columns); ``outputs(point, values)``: the design point's
    output (the mean of the metric over the common noise realisations); ``saved``: a
    ``store.Saved`` that keeps the outputs run so far (every ``SAVE_EVERY`` design points), and
    gives back those of an interrupted run, which are not run again."""
    spec, seed = study.base.sensitivity, study.base.ensemble.seed
    dists = study.base.uncertain
    frames = []
    cr = "\r" if sys.stderr.isatty() else ""  # (one line, rewritten on a terminal; lines in a log)
    for point in range(len(study.points)):
        def model(unit: np.ndarray, point: int = point) -> np.ndarray:
            values = parameter_values(dists, unit)
            name = f"sensitivity.{point}.y"
            before = saved.get(name) if saved is not None else None
            out = np.full(unit.shape[0], np.nan)
            start = 0 if before is None else min(before.shape[0], unit.shape[0])
            if start:
                out[:start] = before[:start]
            for i in range(start, unit.shape[0]):
                out[i] = outputs(point, {key: float(v[i]) for key, v in values.items()})
                last = i == unit.shape[0] - 1
                if saved is not None and ((i + 1) % SAVE_EVERY == 0 or last):
                    saved.put({name: out[:i + 1]})
                if progress and (i % SAVE_EVERY == 0 or last):
                    print(f"{cr}sensitivity: point {point}: {i + 1} of {unit.shape[0]} parameter sets",
                          end="" if cr else "\n", file=sys.stderr, flush=True)
            if progress and cr:
                print(file=sys.stderr)
            return out

        frame = sobol_indices(model, len(dists), spec.samples, seed, spec.bootstrap, list(dists))
        frame.insert(0, "point", point)
        for i, k in enumerate(study.sweep_keys):
            frame.insert(1 + i, k, study.grid[point][k])
        frames.append(frame)
    return pd.concat(frames, ignore_index=True)
