"""The driver's fold of the chunks of each sweep point, in realisation order (the history
statistics, the spectra, the ``target_sem`` test), and its checkpoint for a resumed run."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from .. import history as hist
from .. import psd
from ..store import ForeignFiles, read_arrays, write_arrays

#: ``target_sem`` is tested at every multiple of this many realisations (and never before).
TARGET_STEP = 100


@dataclass
class PointState:
    """What the driver has folded of one sweep point, in realisation order."""

    chunks: list[tuple[int, int, int]]
    folded: int = 0                        # chunks folded
    stop: int | None = None                # realisations kept, once target_sem is met
    tree: hist.Tree | None = None
    edm: list[np.ndarray] = field(default_factory=list)  # per folded chunk: EDM, NaN when failed
    spectrum: psd.Spectrum | None = None   # the spectra's running sums

    @property
    def done(self) -> bool:
        return self.stop is not None or self.folded == len(self.chunks)

    def fold(self, frame: pd.DataFrame, paths: np.ndarray | None, target: float | None,
             estimates: np.ndarray | None = None) -> None:
        """Take the next chunk (``frame``, ``paths`` and the spectral ``estimates`` are read
        only for ``target``, the history tree and the spectra); with ``target``, stop at the
        first multiple of ``TARGET_STEP`` realisations whose EDM standard error is at most
        ``target``.  Failed realisations count in neither the tree nor the spectra."""
        _, start, stop = self.chunks[self.folded]
        keep = stop - start
        if target is not None:
            edm = np.where(frame["status"].to_numpy() == "ok", frame["edm"].to_numpy(dtype=float), np.nan)
            self.edm.append(edm)
            n_stop = _stopping_count(np.concatenate(self.edm), start, target)
            if n_stop is not None:
                self.stop, keep = n_stop, n_stop - start
        if self.tree is not None or self.spectrum is not None:
            ok = (frame["status"] == "ok").to_numpy()[:keep]
            if self.tree is not None:
                self.tree.add(paths[:, :, :keep], ok)
            if self.spectrum is not None:
                self.spectrum.add(estimates[:, :, :keep][:, :, ok])
        self.folded += 1

    def to_arrays(self) -> dict[str, np.ndarray]:
        """What a checkpoint keeps of the point, as named arrays (``restore`` takes it back)."""
        out = {"folded": np.array(self.folded), "stop": np.array(-1 if self.stop is None else self.stop),
               "edm": np.concatenate(self.edm) if self.edm else np.empty(0)}
        if self.tree is not None:
            out.update({f"tree.{name}": a for name, a in self.tree.to_arrays().items()})
        if self.spectrum is not None:
            out.update({f"spectrum.{name}": a for name, a in self.spectrum.to_arrays().items()})
        return out

    def restore(self, arrays: dict[str, np.ndarray]) -> None:
        """Take back what ``to_arrays`` gave (the EDM of the folded chunks joined into one: the
        same values in the same order)."""
        self.folded, stop = int(arrays["folded"]), int(arrays["stop"])
        if not 0 <= self.folded <= len(self.chunks):
            raise ValueError(f"{self.folded} chunks folded of {len(self.chunks)}")
        self.stop = None if stop < 0 else stop
        self.edm = [arrays["edm"]] if arrays["edm"].size else []
        if self.tree is not None:
            self.tree = hist.Tree.from_arrays({name.removeprefix("tree."): a for name, a in arrays.items()
                                               if name.startswith("tree.")})
        if self.spectrum is not None:
            self.spectrum = psd.Spectrum.from_arrays({name.removeprefix("spectrum."): a
                                                      for name, a in arrays.items()
                                                      if name.startswith("spectrum.")})


def _stopping_count(edm: np.ndarray, start: int, target: float) -> int | None:
    """Smallest multiple ``n > start`` of ``TARGET_STEP`` within ``edm`` whose first ``n``
    realisations have an EDM standard error ``<= target`` (failed ones, NaN, left out)."""
    for n in range(TARGET_STEP * (start // TARGET_STEP + 1), edm.shape[0] + 1, TARGET_STEP):
        values = edm[:n][np.isfinite(edm[:n])]
        if values.size > 1 and np.std(values, ddof=1) / math.sqrt(values.size) <= target:
            return n
    return None


class Checkpoint:
    """History statistics folded so far, saved atomically now and then as data
    (``store.write_arrays``: numeric arrays with the run key and their checksum, never pickles): a
    resumed run takes them up; chunks finished after the last save are run again for their paths."""

    def __init__(self, path: Path, key: str, every: float):
        self.path, self.key, self.every = path, key, every
        self.saved = time.monotonic()
        self.folded: set[tuple[int, int, int]] = set()  # the chunks the file holds

    def load(self, states: list[PointState]) -> None:
        """Restore ``states`` from the file, where there is one; ``ForeignFiles`` where it is
        another run's, damaged or not a checkpoint."""
        if not self.path.exists():
            return
        key, arrays = read_arrays(self.path)
        if key != self.key:
            raise ForeignFiles(f"{self.path}: the history statistics of another run; remove it (the chunks "
                               "of this run then run again for their paths), or use another --out folder")
        try:
            for p, state in enumerate(states):
                state.restore({name.split(".", 1)[1]: a for name, a in arrays.items()
                               if name.split(".", 1)[0] == str(p)})
        except (KeyError, ValueError, TypeError, IndexError) as exc:
            raise ForeignFiles(f"{self.path}: does not fit this run's chunks ({exc}); remove it") from None
        self._saved(states)

    def save(self, states: list[PointState], force: bool = False) -> None:
        if not force and time.monotonic() - self.saved < self.every:
            return
        write_arrays(self.path, {f"{p}.{name}": a for p, state in enumerate(states)
                                 for name, a in state.to_arrays().items()}, self.key)
        self.saved = time.monotonic()
        self._saved(states)

    def _saved(self, states: list[PointState]) -> None:
        self.folded = {c for state in states for c in state.chunks[:state.folded]}
