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
    if owner.get("host") != socket.gethostname():
        return True  # another machine's run: it cannot be checked from here
    try:
        os.kill(int(owner["pid"]), 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        pass  # another user's live process
    except (KeyError, TypeError, ValueError):
        return False  # not a lock this program wrote
    started = _started(int(owner["pid"]))
    return owner.get("started") is None or started is None or started == owner["started"]


@contextmanager
def lock_folder(directory: Path) -> Iterator[None]:
    """Own ``directory`` for one run: a second run into it while the first lives is refused
    (``FolderInUse``, naming the process and host); a lock left by a killed run on this host
    (its process gone) is taken over."""
    path = directory / LOCK
    me = {"pid": os.getpid(), "host": socket.gethostname(), "started": _started(os.getpid()),
          "since": time.strftime("%Y-%m-%d %H:%M:%S")}
    for _ in range(100):
        try:
            fd = os.open(path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
        except FileExistsError:
            try:
                text = path.read_text()
                owner = json.loads(text)
            except FileNotFoundError:
                continue  # released meanwhile
            except (OSError, ValueError):
                text, owner = None, {}
            if isinstance(owner, dict) and _alive(owner):
                raise FolderInUse(f"{directory}: in use by the run of process {owner.get('pid')} on host "
                                  f"{owner.get('host')} (since {owner.get('since')}); wait for it, or use another "
                                  f"--out folder (if that run is gone, remove {path})") from None
            _take_over(path, text)
            continue
        with os.fdopen(fd, "w") as stream:
            json.dump(me, stream)
        break
    else:
        raise FolderInUse(f"{directory}: could not take the lock {path}")
    try:
        yield
    finally:
        path.unlink(missing_ok=True)


def _take_over(path: Path, stale: str | None) -> None:
    """Remove the lock of a dead run, unless another run took it over meanwhile."""
    aside = path.with_name(f"{LOCK}.{os.getpid()}")
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


def run_key(scenario_text: str, plan: list[tuple[int, int, int]]) -> str:
    """Fingerprint of a run (scenario text and chunk plan): parts of another run are never reused."""
    digest = hashlib.sha256(scenario_text.encode())
    digest.update(json.dumps(plan).encode())
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
