"""Parquet results: atomic part files per chunk, consolidation, provenance metadata."""

from __future__ import annotations

import hashlib
import json
import os
import platform
import socket
import time
from collections.abc import Iterator
from contextlib import contextmanager
from functools import lru_cache
from importlib import metadata as importlib_metadata
from pathlib import Path

import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from . import __version__

DEPENDENCIES = ("numpy", "scipy", "numba", "pandas", "pyarrow", "dask", "distributed", "pydantic")


@lru_cache(maxsize=1)
def _dependency_versions() -> str:
    """The installed versions of the dependencies and Python, as JSON (read once a process:
    the package metadata lookups cost about 16 ms)."""
    versions = {}
    for name in DEPENDENCIES:
        try:
            versions[name] = importlib_metadata.version(name)
        except importlib_metadata.PackageNotFoundError:
            versions[name] = "missing"
    versions["python"] = platform.python_version()
    return json.dumps(versions, sort_keys=True)


def provenance(scenario_text: str, source: str, seed: int, scheduler: str) -> dict[str, str]:
    """Key-value metadata stored in both result files."""
    return {
        "vines_stoch.version": __version__,
        "vines_stoch.scenario": scenario_text,
        "vines_stoch.source": source,
        "vines_stoch.seed": str(seed),
        "vines_stoch.scheduler": scheduler,
        "vines_stoch.dependencies": _dependency_versions(),
    }


def write_table(frame: pd.DataFrame, path: Path, meta: dict[str, str] | None = None) -> None:
    """Write a DataFrame as Parquet atomically (temporary file, then rename)."""
    table = pa.Table.from_pandas(frame, preserve_index=False)
    if meta:
        table = table.replace_schema_metadata({**(table.schema.metadata or {}), **meta})
    tmp = path.with_name(path.name + ".tmp")
    pq.write_table(table, tmp)
    os.replace(tmp, path)


class FolderInUse(OSError):
    """An output folder another live run is writing."""


#: The lock file of an output folder.
LOCK = ".lock"


def _started(pid: int) -> str | None:
    """Start time of process ``pid`` (clock ticks since boot, from ``/proc``), None where unknown:
    tells a live run from a new process that reuses a dead run's id."""
    try:
        with open(f"/proc/{pid}/stat", "rb") as stream:
            return stream.read().rsplit(b")", 1)[1].split()[19].decode()
    except (OSError, IndexError):
        return None


def _alive(owner: dict) -> bool:
    """True when the run described by a lock's content may still be running."""
    try:
        pid, host = int(owner["pid"]), owner["host"]
    except (KeyError, TypeError, ValueError):
        return False  # not a lock this program wrote (empty, cut short)
    if host != socket.gethostname():
        return True  # another machine's run: it cannot be checked from here
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        pass  # another user's live process
    started = _started(pid)
    return owner.get("started") is None or started is None or started == owner["started"]


def _owner(path: Path) -> tuple[str | None, dict] | None:
    """``(text, owner)`` of a lock file, None where there is none."""
    try:
        text = path.read_text()
    except FileNotFoundError:
        return None
    except OSError:
        return None, {}
    try:
        owner = json.loads(text)
    except ValueError:
        owner = {}
    return text, owner if isinstance(owner, dict) else {}


def _in_use(directory: Path, path: Path, owner: dict) -> FolderInUse:
    what = "the run" if path.name == LOCK else f"the {path.name.removeprefix(LOCK + '.')} run"
    return FolderInUse(f"{directory}: in use by {what} of process {owner.get('pid')} "
                       f"on host {owner.get('host')} (since {owner.get('since')}); wait for it, "
                       f"or use another --out folder (if that run is gone, remove {path})")


def _acquire(directory: Path, path: Path) -> None:
    """Create the lock file ``path``, taking over a dead run's; FolderInUse if a live run holds it."""
    me = {"pid": os.getpid(), "host": socket.gethostname(), "started": _started(os.getpid()),
          "since": time.strftime("%Y-%m-%d %H:%M:%S")}
    for _ in range(100):
        try:
            fd = os.open(path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
        except FileExistsError:
            found = _owner(path)
            if found is None:
                continue  # released meanwhile
            text, owner = found
            if _alive(owner):
                raise _in_use(directory, path, owner) from None
            _take_over(path, text)
            continue
        with os.fdopen(fd, "w") as stream:
            json.dump(me, stream)
        return
    raise FolderInUse(f"{directory}: could not take the lock {path}")


@contextmanager
def lock_folder(directory: Path, shard: str | None = None) -> Iterator[None]:
    """Own ``directory`` for one run: a second run into it while the first lives is refused
    (``FolderInUse``, naming the process and host); a lock left by a killed run on this host
    (its process gone) is taken over.  Shards of one study (``shard``, e.g. ``"shard-0-of-2"``)
    share the folder with each other, each with a lock of its own, but not with a whole run."""
    path = directory / (LOCK if shard is None else f"{LOCK}.{shard}")
    _acquire(directory, path)
    try:
        others = [directory / LOCK] if shard is not None else sorted(directory.glob(f"{LOCK}.shard-*"))
        for other in others:
            found = _owner(other)
            if found is not None and _alive(found[1]):
                raise _in_use(directory, other, found[1])
        yield
    finally:
        path.unlink(missing_ok=True)


def _take_over(path: Path, stale: str | None) -> None:
    """Remove the lock of a dead run, unless another run took it over meanwhile."""
    aside = path.with_name(f"{path.name}-stale.{os.getpid()}")
    try:
        os.rename(path, aside)
    except FileNotFoundError:
        return
    if aside.read_text() != stale:  # a live run's fresh lock: put it back, unless a third took the path
        try:
            os.link(aside, path)
        except FileExistsError:
            pass
    aside.unlink()


def run_key(scenario_text: str, plan: list[tuple[int, int, int]], backend: str = "cpu") -> str:
    """Fingerprint of a run (scenario text, chunk plan and, other than the CPU, the backend,
    whose streams differ): parts of another run are never reused."""
    digest = hashlib.sha256(scenario_text.encode())
    digest.update(json.dumps(plan).encode())
    if backend != "cpu":
        digest.update(backend.encode())
    return digest.hexdigest()[:16]


def part_path(directory: Path, point: int, start: int, stop: int) -> Path:
    """File of one finished chunk."""
    return directory / "parts" / f"point{point:05d}_r{start:08d}-{stop:08d}.parquet"


def read_metadata(path: str | Path) -> dict[str, str]:
    """The vines_stoch key-value metadata of a result file."""
    raw = pq.read_schema(path).metadata or {}
    return {k.decode(): v.decode() for k, v in raw.items() if k.startswith(b"vines_stoch.")}


def read_results(directory: str | Path) -> tuple[pd.DataFrame, pd.DataFrame]:
    """``(realizations, summary)`` of a finished run as pandas DataFrames."""
    directory = Path(directory)
    return (pd.read_parquet(directory / "realizations.parquet"),
            pd.read_parquet(directory / "summary.parquet"))
