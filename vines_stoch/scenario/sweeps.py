"""Sweep expansion: the values of each ``[sweep]`` axis, zipped axes, the grid of points and
dotted paths into the raw scenario data."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .errors import MISSING, ScenarioError, format_error
from .fields import MAX_POINTS


def _grid(key: str, spec: Any, source: str) -> list[float] | list[str]:
    """Values of one ``[sweep]`` entry: a list of numbers or of texts, ``{linspace = [a, b, n]}`` or
    ``{logspace = [a, b, n]}``."""
    where = f"sweep.{key}"
    if isinstance(spec, list) and spec and all(isinstance(v, str) for v in spec):
        if len(spec) > MAX_POINTS:
            raise ScenarioError(format_error(source, where, spec, f"{len(spec)} values: a sweep has at most "
                                             f"{MAX_POINTS} points (split the study into several files)"))
        return list(spec)  # a text field's values (e.g. the record files of a suite)
    if isinstance(spec, list):
        values = spec
    elif isinstance(spec, dict) and len(spec) == 1 and next(iter(spec)) in ("linspace", "logspace"):
        kind, args = next(iter(spec.items()))
        if not (isinstance(args, list) and len(args) == 3 and all(isinstance(a, (int, float)) for a in args)
                and isinstance(args[2], int) and not isinstance(args[2], bool) and args[2] >= 1):
            raise ScenarioError(format_error(source, f"{where}.{kind}", args,
                                             "must be [first, last, count] with count an integer >= 1"))
        first, last, count = args
        if count > MAX_POINTS:
            raise ScenarioError(format_error(source, f"{where}.{kind}", args,
                                             f"count {count}: a sweep has at most "
                                             f"{MAX_POINTS} points (split the study into several files)"))
        if kind == "logspace":
            if first <= 0 or last <= 0:
                raise ScenarioError(format_error(source, f"{where}.logspace", args,
                                                 "first and last must be > 0 (values, not exponents)"))
            values = list(np.geomspace(first, last, count))
        else:
            values = list(np.linspace(first, last, count))
    else:
        raise ScenarioError(format_error(source, where, spec,
                                         "must be a list of values, {linspace = [first, last, count]} "
                                         "or {logspace = [first, last, count]}"))
    if not values:
        raise ScenarioError(format_error(source, where, spec, "must hold at least one value"))
    if len(values) > MAX_POINTS:
        raise ScenarioError(format_error(source, where, spec, f"{len(values)} values: a sweep has at most "
                                         f"{MAX_POINTS} points (split the study into several files)"))
    for v in values:
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise ScenarioError(format_error(source, where, spec, "values must be finite numbers "
                                             "(or all texts, for a text field such as a record's file)"))
    return [float(v) for v in values]


def set_path(data: dict[str, Any], key: str, value: Any) -> None:
    """Set the field addressed by a dotted path (``loads.0.velocity``) in raw scenario data."""
    parts = key.split(".")
    node: Any = data
    for part in parts[:-1]:
        node = node[_index(part)] if isinstance(node, list) else node[part]
    last = parts[-1]
    if isinstance(node, list):
        node[_index(last)] = value
    else:
        node[last] = value


def get_path(data: dict[str, Any], key: str) -> Any:
    """The value addressed by a dotted path, or raise KeyError/IndexError/ValueError."""
    node: Any = data
    for part in key.split("."):
        node = node[_index(part)] if isinstance(node, list) else node[part]
    return node


def _index(part: str) -> int:
    """A list index of a dotted path: digits only (``-1`` names nothing)."""
    if not part.isdigit():
        raise ValueError(f"{part!r} is not a list index")
    return int(part)



def _zipped(spec: Any, sweep: dict[str, Any], source: str) -> list[str]:
    """Keys of ``sweep.zip``: swept together, value by value, as one axis of the grid."""
    if not (isinstance(spec, list) and all(isinstance(k, str) for k in spec)):
        raise ScenarioError(format_error(source, "sweep.zip", spec, "must be a list of swept keys"))
    for key in spec:
        if key not in sweep:
            raise ScenarioError(format_error(source, "sweep.zip", spec,
                                             f"names {key!r}, which is not swept in [sweep]"))
    return list(dict.fromkeys(spec))


def _product(grids: dict[str, list], zipped: list[str], source: str) -> list[dict[str, float | str]]:
    """Sweep points: the cartesian product of the axes, zipped keys forming one axis."""
    if zipped:
        lengths = {len(grids[k]) for k in zipped}
        if len(lengths) > 1:
            sizes = ", ".join(f"{k}: {len(grids[k])}" for k in zipped)
            raise ScenarioError(format_error(source, "sweep.zip", zipped,
                                             f"zipped keys need equally many values ({sizes})"))
    size = math.prod([len(grids[zipped[0]])] if zipped else []) * math.prod(
        len(g) for k, g in grids.items() if k not in zipped)
    if size > MAX_POINTS:
        raise ScenarioError(format_error(source, "sweep", MISSING, f"{size} points; a sweep has at most "
                                         f"{MAX_POINTS} points (split the study into several files)"))
    axes: list[list[dict[str, float]]] = []
    if zipped:
        axes.append([{k: grids[k][i] for k in zipped} for i in range(len(grids[zipped[0]]))])
    axes += [[{k: v} for v in grid] for k, grid in grids.items() if k not in zipped]
    points: list[dict[str, float]] = [{}]
    for axis in axes:
        points = [{**p, **a} for p in points for a in axis]
    return [{k: p[k] for k in grids} for p in points]
