"""Monte Carlo ensembles: chunk plan, per-realisation random streams, dask execution.

Realisation ``r`` of sweep point ``p`` draws its noise from
``PCG64(SeedSequence(seed, spawn_key=(p, r)))``: its numbers depend on nothing else, so results
are bitwise identical for any chunk size, worker count or scheduler.
"""

from __future__ import annotations

import json
import math
import os
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import dask
import numpy as np
import pandas as pd
from dask.callbacks import Callback

from .kernels import sample_buffer, simulate
from .metrics import METRICS, finish, summarise
from .scenario import Study
from .scene import Scene, build_scene
from .store import part_path, provenance, read_results, run_key, write_table

#: Target work of one chunk, in path-steps (about 0.1-0.3 s of compute).
CHUNK_STEPS = 5_000_000


def generator(seed: int, point: int, realization: int) -> np.random.Generator:
    """The random stream of one realisation."""
    return np.random.Generator(np.random.PCG64(np.random.SeedSequence(seed, spawn_key=(point, realization))))


def run_chunk(scene: Scene, seed: int, point: int, start: int, stop: int) -> pd.DataFrame:
    """Realisations ``start..stop-1`` of one sweep point, one row each."""
    rows = []
    for r in range(start, stop):
        samples = sample_buffer(scene)
        raw = simulate(scene, generator(seed, point, r) if scene.has_noise else None, samples=samples)
        rows.append({"point": point, "realization": r, **finish(raw, scene, samples)})
    frame = pd.DataFrame(rows)
    frame["regime"] = frame["regime"].astype("string")
    return frame


@dataclass
class Plan:
    """Scenes of the sweep points and the chunks ``(point, start, stop)`` covering them."""

    scenes: list[Scene]
    realizations: list[int]
    chunks: list[tuple[int, int, int]]


def plan(study: Study, workers: int, chunk: int | None = None, realizations: int | None = None) -> Plan:
    """Split every sweep point's realisations into chunks (``chunk`` 0 or None: automatic)."""
    scenes = [build_scene(s) for s in study.points]
    wanted = realizations or study.base.ensemble.realizations
    chunk = study.base.ensemble.chunk if chunk is None else chunk
    counts = [wanted if scene.has_noise else 1 for scene in scenes]
    chunks = []
    for p, (scene, n) in enumerate(zip(scenes, counts)):
        size = chunk or _auto_chunk(scene, n, workers)
        chunks += [(p, s, min(s + size, n)) for s in range(0, n, size)]
    return Plan(scenes, counts, chunks)


def _auto_chunk(scene: Scene, n: int, workers: int) -> int:
    by_cost = max(1, CHUNK_STEPS // max(scene.n_steps, 1))
    by_balance = max(1, math.ceil(n / (4 * max(workers, 1))))
    return min(by_cost, by_balance)


class _Progress(Callback):
    """Chunks finished out of the total, with rate and ETA, on standard error."""

    def __init__(self, total: int, done: int, enabled: bool):
        super().__init__()
        self.total, self.done, self.enabled = total, done, enabled
        self.start = time.perf_counter()
        self.first = done
        self.tty = sys.stderr.isatty()
        self.last_line = 0.0

    def _posttask(self, key, result, dsk, state, worker_id):
        if not str(key).startswith("chunk"):
            return
        self.done += 1
        if not self.enabled:
            return
        now = time.perf_counter()
        if not self.tty and now - self.last_line < 5.0 and self.done < self.total:
            return
        self.last_line = now
        rate = (self.done - self.first) / max(now - self.start, 1e-9)
        eta = (self.total - self.done) / rate if rate > 0 else float("inf")
        line = f"chunks {self.done}/{self.total}  {rate:.2f}/s  eta {eta:.0f}s"
        print(("\r" + line) if self.tty else line, end="" if self.tty else "\n", file=sys.stderr, flush=True)

    def _finish(self, dsk, state, errored):
        if self.enabled and self.tty:
            print(file=sys.stderr)


def run(study: Study, directory: str | Path | None = None, *, workers: int | None = None,
        chunk: int | None = None, realizations: int | None = None, resume: bool = False,
        scheduler: str | None = None, progress: bool = False) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Run a validated study; write ``realizations.parquet`` and ``summary.parquet`` into
    ``directory`` (default: the scenario's output directory) and return them as DataFrames.

    ``workers``: threads of the embedded scheduler (default: all cores).  ``scheduler``: the
    address of a running ``dask.distributed`` scheduler to use instead.  ``resume``: keep the
    chunks a previous, interrupted run of the same scenario finished.
    """
    base = study.base
    directory = Path(directory or base.output.directory or f"results/{base.name}")
    workers = workers or os.cpu_count() or 1
    the_plan = plan(study, workers, chunk, realizations)
    seed = base.ensemble.seed
    key = run_key(study.text, the_plan.chunks)
    (directory / "parts").mkdir(parents=True, exist_ok=True)
    manifest = directory / "parts" / "manifest.json"
    if resume and manifest.exists() and json.loads(manifest.read_text()).get("key") != key:
        raise ValueError(f"{directory}: --resume found parts of a different scenario or chunk plan; "
                         "use another --out directory or run without --resume")
    if not resume:
        for old in (directory / "parts").glob("*.parquet"):
            old.unlink()
    manifest.write_text(json.dumps({"key": key, "chunks": len(the_plan.chunks)}))

    todo = [c for c in the_plan.chunks if not part_path(directory, *c).exists()]

    def task(p: int, start: int, stop: int) -> str:
        frame = run_chunk(the_plan.scenes[p], seed, p, start, stop)
        for k in study.sweep_keys:
            frame.insert(2, k, study.grid[p][k])
        path = part_path(directory, p, start, stop)
        write_table(frame, path)
        return str(path)

    tasks = [dask.delayed(task, pure=False)(*c, dask_key_name=f"chunk-{c[0]}-{c[1]}") for c in todo]
    done = len(the_plan.chunks) - len(todo)
    where = "embedded threads"
    with _Progress(len(the_plan.chunks), done, progress):
        if scheduler:
            from dask.distributed import Client

            with Client(scheduler) as client:
                where = f"dask.distributed at {scheduler}"
                dask.compute(*tasks, scheduler=client)
        else:
            dask.compute(*tasks, scheduler="threads", num_workers=workers)

    frames = [pd.read_parquet(part_path(directory, *c)) for c in the_plan.chunks]
    realizations_df = pd.concat(frames, ignore_index=True).sort_values(["point", "realization"],
                                                                        kind="stable", ignore_index=True)
    summary_df = summarise(realizations_df, study.sweep_keys)
    meta = provenance(study.text, study.source, seed, where)
    write_table(realizations_df, directory / "realizations.parquet", meta)
    write_table(summary_df, directory / "summary.parquet", meta)
    return read_results(directory)


__all__ = ["METRICS", "generator", "plan", "run", "run_chunk"]
