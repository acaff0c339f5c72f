"""Parquet results: atomic part files per chunk, consolidation, provenance metadata."""

from __future__ import annotations

import hashlib
import json
import os
import platform
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
