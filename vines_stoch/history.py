"""Ensemble statistics of time histories without storing paths (history.parquet).

Each realisation reports its signals (``x1`` and ``E1`` unless the scenario names others:
``signals.py``) on a decimated grid.  The realisations of a sweep
point are grouped into leaves of ``BLOCK`` consecutive realisations (by index, whatever the
chunks), and leaves into a binary tree.  Every node holds the exact count, mean and sum of
squared deviations (merged exactly, Chan et al.) and a sorted quantile buffer of at most
``BLOCK`` values per grid point, each standing for ``weight`` realisations: merging two nodes
merges their buffers and, past ``BLOCK`` values, keeps every other one (Munro-Paterson), so
memory is ``O(BLOCK log n)`` per grid point, never ``O(n)``.

The tree depends on realisation indices alone, so the statistics are bitwise the same for any
chunk size, worker count or completion order.  With ``n <= BLOCK`` ok realisations the
quantiles are exact; beyond, each compaction moves a quantile by at most one buffer weight in
rank, and the bound on the accumulated rank error is reported (``rank_error``, a fraction of
``n``).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from .scenario import History, quantile_name

#: Realisations per leaf, and the largest quantile buffer of a node.
BLOCK = 512
def grid(n_steps: int, points: int) -> tuple[int, int]:
    """``(stride, size)`` of the history grid: rows at ``t = j stride dt``, ``j < size``, with
    ``stride`` the largest whole number of steps that gives at least ``points`` rows (or every
    step when the scene has fewer)."""
    stride = max(1, n_steps // max(points - 1, 1))
    return stride, n_steps // stride + 1


@dataclass
class Node:
    """Statistics of the ok realisations among a run of consecutive ones."""

    count: int                # ok realisations
    mean: np.ndarray          # (signals, grid)
    m2: np.ndarray            # (signals, grid): sum of squared deviations from the mean
    values: np.ndarray        # (signals, grid, m): sorted along the last axis
    weight: int = 1           # realisations each buffered value stands for
    rank_error: float = 0.0   # bound on the rank error of the buffer, in realisations

    @classmethod
    def leaf(cls, paths: np.ndarray) -> Node:
        """Node of raw paths, shape ``(signals, grid, m)``."""
        paths = np.ascontiguousarray(paths)  # one memory layout, one summation order
        m = paths.shape[2]
        mean = paths.mean(axis=2) if m else np.zeros(paths.shape[:2])
        m2 = ((paths - mean[:, :, None]) ** 2).sum(axis=2)
        return cls(m, mean, m2, np.sort(paths, axis=2))


def _coarsen(node: Node, weight: int) -> tuple[np.ndarray, float]:
    """The node's buffer brought to ``weight`` by keeping every other value, and its error
    (never more than the node's count: no rank moves further than the values it holds)."""
    values, w, err = node.values, node.weight, node.rank_error
    while w < weight:
        values = values[:, :, 1::2] if values.shape[2] % 2 == 0 else values[:, :, 0::2]
        err += w
        w *= 2
    return values, min(err, node.count)


def merge(a: Node, b: Node) -> Node:
    """Node of two adjacent runs (``a`` before ``b``): exact moments, compacted buffer."""
    if a.count == 0:
        return b
    if b.count == 0:
        return a
    n = a.count + b.count
    delta = b.mean - a.mean
    mean = a.mean + delta * (b.count / n)
    m2 = a.m2 + b.m2 + delta * delta * (a.count * b.count / n)
    weight = max(a.weight, b.weight)
    va, ea = _coarsen(a, weight)
    vb, eb = _coarsen(b, weight)
    values = np.sort(np.concatenate([va, vb], axis=2), axis=2, kind="stable")
    err = ea + eb
    if values.shape[2] > BLOCK:
        values = values[:, :, 1::2] if values.shape[2] % 2 == 0 else values[:, :, 0::2]
        err += weight
        weight *= 2
    return Node(n, mean, m2, values, weight, min(err, n))


@dataclass
class Tree:
    """Streaming statistics of one sweep point, fed realisations in index order: a leaf being
    filled and at most one finished node per level (a binary counter)."""

    seen: int = 0                                           # realisations fed so far
    pending: list[np.ndarray] = field(default_factory=list)  # ok paths of the open leaf
    levels: dict[int, Node] = field(default_factory=dict)

    def add(self, paths: np.ndarray, ok: np.ndarray) -> None:
        """Feed the next realisations: paths ``(signals, grid, m)``, ``ok`` marks those that count."""
        start = 0
        while start < paths.shape[2]:
            take = min(paths.shape[2] - start, BLOCK - self.seen % BLOCK)
            piece = paths[:, :, start:start + take]
            self.pending.append(piece[:, :, ok[start:start + take]])
            self.seen += take
            start += take
            if self.seen % BLOCK == 0:
                self._carry(Node.leaf(np.concatenate(self.pending, axis=2)))
                self.pending = []

    def to_arrays(self) -> dict[str, np.ndarray]:
        """The tree as named numeric arrays (a checkpoint's content); ``from_arrays`` gives it
        back exactly (the open leaf's pieces joined into one: the same values in the same
        order)."""
        out = {"seen": np.array(self.seen), "pieces": np.array(len(self.pending)),
               "levels": np.array(sorted(self.levels), dtype=np.int64)}
        if self.pending:
            out["pending"] = np.concatenate(self.pending, axis=2)
        for level, node in self.levels.items():
            out[f"{level}.counts"] = np.array([node.count, node.weight])
            out[f"{level}.rank_error"] = np.array(node.rank_error)
            out[f"{level}.mean"], out[f"{level}.m2"], out[f"{level}.values"] = node.mean, node.m2, node.values
        return out

    @classmethod
    def from_arrays(cls, arrays: Mapping[str, np.ndarray]) -> Tree:
        """The tree ``to_arrays`` wrote."""
        levels = {}
        for level in arrays["levels"].tolist():
            count, weight = arrays[f"{level}.counts"].tolist()
            levels[level] = Node(count, arrays[f"{level}.mean"], arrays[f"{level}.m2"],
                                 arrays[f"{level}.values"], weight, float(arrays[f"{level}.rank_error"]))
        return cls(int(arrays["seen"]), [arrays["pending"]] if int(arrays["pieces"]) else [], levels)

    def _carry(self, node: Node) -> None:
        level = 0
        while level in self.levels:
            node = merge(self.levels.pop(level), node)
            level += 1
        self.levels[level] = node

    def result(self) -> Node | None:
        """The statistics of every realisation fed (None before any)."""
        nodes = [self.levels[k] for k in sorted(self.levels, reverse=True)]  # left to right
        if self.pending:
            nodes.append(Node.leaf(np.concatenate(self.pending, axis=2)))
        if not nodes:
            return None
        total = nodes[-1]
        for node in reversed(nodes[:-1]):  # smallest first: the light buffers coarsen least
            total = merge(node, total)
        return total


def frame(node: Node | None, spec: History, t: np.ndarray) -> pd.DataFrame:
    """Rows of history.parquet for one sweep point: ``t``, ``n`` and, per signal, mean,
    standard deviation, the quantiles asked for and the buffer's rank-error bound."""
    columns: dict[str, np.ndarray] = {"t": t}
    n = node.count if node is not None else 0
    columns["n"] = np.full(t.shape[0], n, dtype=np.int64)
    for s, name in enumerate(spec.signals):
        if n == 0:
            nan = np.full(t.shape[0], np.nan)
            columns[f"{name}_mean"], columns[f"{name}_std"] = nan, nan
            for q in spec.quantiles:
                columns[f"{name}_{quantile_name(q)}"] = nan
            continue
        columns[f"{name}_mean"] = node.mean[s]
        columns[f"{name}_std"] = np.sqrt(node.m2[s] / (n - 1)) if n > 1 else np.full(t.shape[0], np.nan)
        quantiles = np.quantile(node.values[s], spec.quantiles, axis=1)
        for q, row in zip(spec.quantiles, quantiles):
            columns[f"{name}_{quantile_name(q)}"] = row
    columns["rank_error"] = np.full(t.shape[0], node.rank_error / n if n else 0.0)
    return pd.DataFrame(columns)
