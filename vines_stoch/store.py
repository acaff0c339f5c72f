"""Parquet results: atomic part files per chunk, consolidation, provenance metadata, and the
identity of an output folder's files.

Every file a run writes into its folder carries the run's key (``run_key``: scenario text, seed,
chunk plan, backend): part files and result files in their Parquet metadata, the checkpoint of
the history statistics among its arrays.  Nothing in a folder is trusted for being there: a run
reuses only parts with its own key, a report reads only results whose keys agree, and no file
is read in a format that can execute code (Parquet, JSON, npz without pickles).  A new run
deletes only files this program wrote (recognised by their metadata) and refuses, naming them,
to start beside files it did not write.
"""

from __future__ import annotations

import hashlib
import json
import os
import platform
import re
import socket
import struct
import time
import zipfile
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from functools import lru_cache
from importlib import metadata as importlib_metadata
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from . import __version__
from .streams.rng import NORMALS

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


#: Metadata key of the run key, in every part and result file.
KEY = "vines_stoch.run_key"
#: The result files a run (or ``vines-stoch fragility``) writes into its folder.
RESULTS = ("summary.parquet", "realizations.parquet", "history.parquet", "events.parquet",
           "poincare.parquet", "spectra.parquet", "paths.parquet", "rare.parquet", "sensitivity.parquet",
           "fragility.parquet")
#: The parts' manifest (the run key and the number of chunks), the history statistics'
#: checkpoint and the studies' (``Saved``), in ``DIR/parts``.
MANIFEST, CHECKPOINT, STUDIES = "manifest.json", "history.npz", "studies.npz"
#: Names of the files in ``DIR/parts`` that only a run writes: parts, and temporary files of an
#: atomic write that a killed run can leave (``write_table``, ``write_arrays``, the manifest).
_PART = re.compile(r"point\d{5}_r\d{8}-\d{8}\.parquet")
_LEFT_BEHIND = re.compile(r"(point\d{5}_r\d{8}-\d{8}\.parquet|history\.npz|studies\.npz)\.tmp"
                          r"|manifest\.json\.\d+")
#: Marker of a checkpoint file (its format, should it ever change).
_ARRAYS_FORMAT = "vines-stoch arrays 1"


class ForeignFiles(ValueError):
    """An output folder holds files of another run, or files this program did not write."""


def provenance(scenario_text: str, source: str, seed: int, scheduler: str, backend: str = "cpu",
               key: str | None = None) -> dict[str, str]:
    """Key-value metadata stored in every result file (``key``: the run key, ``run_key``)."""
    return {
        "vines_stoch.version": __version__,
        "vines_stoch.scenario": scenario_text,
        "vines_stoch.source": source,
        "vines_stoch.seed": str(seed),
        "vines_stoch.backend": backend,
        "vines_stoch.scheduler": scheduler,
        "vines_stoch.dependencies": _dependency_versions(),
        **({KEY: key} if key else {}),
    }


def write_table(frame: pd.DataFrame, path: Path, meta: dict[str, str] | None = None) -> None:
    """Write a DataFrame as Parquet atomically (temporary file, then rename)."""
    table = pa.Table.from_pandas(frame, preserve_index=False)
    if meta:
        table = table.replace_schema_metadata({**(table.schema.metadata or {}), **meta})
    tmp = path.with_name(path.name + ".tmp")
    pq.write_table(table, tmp)
    os.replace(tmp, path)


class OutsideFolder(ValueError):
    """A path the program would write lies outside the folder the user named."""


def component(name: str) -> str:
    """``name`` (a scenario's, from a file or a results folder's metadata) as one path component
    that stays where it is put: every run of characters other than letters, digits, ``_``, ``-``
    and ``.`` becomes ``_`` (separators, NUL), leading dots go (``..``), ``run`` if nothing is
    left."""
    return re.sub(r"[^\w.-]+", "_", name).lstrip(".") or "run"


def within(path: Path, root: Path) -> Path:
    """``path``, made sure to lie inside ``root`` once links are followed (a link planted in the
    folder that points elsewhere is refused, ``OutsideFolder``)."""
    resolved, base = Path(path).resolve(), Path(root).resolve()
    if resolved != base and base not in resolved.parents:
        raise OutsideFolder(f"{path}: leads outside {root} (to {resolved}); the program writes only inside "
                            "the folder it is given: remove the link, or use another folder")
    return Path(path)


def fresh(path: Path) -> Path:
    """``path`` with a link planted there removed, so that writing it writes a new file in its
    folder, never through the link."""
    path = Path(path)
    if path.is_symlink():
        path.unlink()
    return path


class DamagedFile(ValueError):
    """A file of the program's in an output folder cannot be read: named as damaged."""


class UnfinishedRun(ValueError):
    """A new run would discard the kept work of an unfinished (interrupted or sharded) run."""


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
    """Fingerprint of a run (scenario text, seed included, chunk plan, the definition of the
    streams' normals, ``rng.NORMALS``, and, other than the CPU, the backend, whose streams
    differ): parts of another run are never reused."""
    digest = hashlib.sha256(scenario_text.encode())
    digest.update(json.dumps(plan).encode())
    digest.update(NORMALS.encode())
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


def _starts_as_parquet(path: Path) -> bool:
    """True when ``path`` begins with Parquet's magic bytes (a Parquet file, readable or not)."""
    try:
        with path.open("rb") as stream:
            return stream.read(4) == b"PAR1"
    except OSError:
        return False


def _parquet_metadata(path: Path) -> dict[str, str] | None:
    """``read_metadata`` of a file, None where it is not a Parquet file that can be read."""
    try:
        return read_metadata(path)
    except (OSError, ValueError, pa.ArrowException):
        return None


def png_text(path: Path) -> dict[str, str]:
    """The text entries (``tEXt`` chunks) of a PNG file before its image data; {} for any other
    file."""
    found: dict[str, str] = {}
    try:
        with path.open("rb") as stream:
            if stream.read(8) != b"\x89PNG\r\n\x1a\n":
                return found
            while len(head := stream.read(8)) == 8:
                length, kind = struct.unpack(">I4s", head)
                if kind == b"IDAT" or length > 1 << 20:
                    break
                data = stream.read(length + 4)[:length]  # (and the chunk's CRC)
                if kind == b"tEXt":
                    name, _, text = data.partition(b"\0")
                    found[name.decode("latin-1")] = text.decode("latin-1")
    except OSError:
        pass
    return found


def svg_identifier(path: Path) -> str:
    """The identifier (``dc:identifier``) of an SVG file's metadata that ``plotting.save``
    writes, "" where there is none (read from the file's first 64 KiB)."""
    try:
        with path.open("rb") as stream:
            head = stream.read(1 << 16).decode("utf-8", "replace")
    except OSError:
        return ""
    start, end = head.find("<dc:identifier>"), head.find("</dc:identifier>")
    return head[start + len("<dc:identifier>"):end] if 0 <= start < end else ""


def _digest(arrays: Mapping[str, np.ndarray]) -> str:
    """sha256 of named arrays: each one's name, type, shape and bytes, in name order."""
    h = hashlib.sha256()
    for name in sorted(arrays):
        a = np.ascontiguousarray(arrays[name])
        h.update(json.dumps([name, a.dtype.str, a.shape]).encode())
        h.update(a.tobytes())
    return h.hexdigest()


def write_arrays(path: Path, arrays: Mapping[str, np.ndarray], key: str) -> None:
    """Write numeric arrays, the run ``key`` and their checksum as an ``.npz`` file, atomically
    (the checkpoint of the history statistics: data that ``read_arrays`` loads without pickles)."""
    header = json.dumps({"format": _ARRAYS_FORMAT, "key": key, "sha256": _digest(arrays)})
    tmp = path.with_name(path.name + ".tmp")
    with tmp.open("wb") as stream:
        np.savez(stream, header=np.array(header), **arrays)
    os.replace(tmp, path)


def read_arrays(path: Path) -> tuple[str, dict[str, np.ndarray]]:
    """``(key, arrays)`` of a file ``write_arrays`` wrote; ``ForeignFiles`` where it is not such a
    file or its arrays do not match their checksum (nothing in it is ever unpickled)."""
    try:
        with np.load(path, allow_pickle=False) as npz:
            arrays = {name: npz[name] for name in npz.files}
        header = json.loads(str(arrays.pop("header")))
        if header.get("format") != _ARRAYS_FORMAT:
            raise ValueError("not a checkpoint")
    except (OSError, ValueError, KeyError, TypeError, AttributeError, EOFError, zipfile.BadZipFile):
        raise ForeignFiles(f"{path}: not a checkpoint vines-stoch wrote; remove it (a resumed run then runs "
                           "the chunks it would have kept again) or use another --out folder") from None
    if header.get("sha256") != _digest(arrays):
        raise ForeignFiles(f"{path}: damaged (its arrays do not match their checksum); remove it (a "
                           "resumed run then runs the chunks it would have kept again)")
    return str(header.get("key")), arrays


class Saved:
    """What the studies after an ensemble have done so far (the rare-event replicas, the Sobol
    design's outputs: ``rare.table``, ``sensitivity.table``), as named numeric arrays saved
    atomically in ``DIR/parts/studies.npz`` (``write_arrays``) each time ``put`` is called: a
    resumed run takes them up where the interrupted one stopped, to the same numbers.  Without a
    folder it keeps nothing."""

    def __init__(self, path: Path | None, key: str, resume: bool):
        self.path, self.key, self.arrays = path, key, {}
        if path is not None and resume and path.exists():
            found, self.arrays = read_arrays(path)
            if found != key:
                raise ForeignFiles(f"{path}: the studies of another run; remove it (its rare-event "
                                   "estimates and Sobol indices then run again), or use another --out folder")

    def get(self, name: str) -> np.ndarray | None:
        """The array saved as ``name``, or None."""
        return self.arrays.get(name)

    def put(self, arrays: Mapping[str, np.ndarray]) -> None:
        """Keep ``arrays`` (by name, replacing those of the same names) and save them all."""
        self.arrays.update({name: np.asarray(a) for name, a in arrays.items()})
        if self.path is not None:
            write_arrays(self.path, self.arrays, self.key)


def _manifest(directory: Path) -> dict | None:
    """The parts' manifest of a folder (``{"key", "chunks", "source"}``), None where there is none or
    it is not one a run wrote."""
    try:
        found = json.loads((directory / "parts" / MANIFEST).read_text())
    except (OSError, ValueError):
        return None
    return found if isinstance(found, dict) and isinstance(found.get("key"), str) else None


def _written_here(path: Path) -> bool:
    """Whether this program wrote ``path``, a result file (its metadata, of any version) or a
    fragility plot (its text entries, or an SVG's identifier, hold a run key)."""
    if not path.is_file() or path.is_symlink():
        return False
    if path.suffix == ".svg":
        return svg_identifier(path).startswith(f"{KEY} ")
    return KEY in png_text(path) if path.suffix == ".png" else bool(_parquet_metadata(path))


def _written_in_parts(path: Path) -> bool:
    """Whether this program wrote ``path``, a file in ``DIR/parts``: a part (its metadata holds a
    run key), the manifest, the checkpoint, or a temporary file an interrupted atomic write left
    (known by its name alone)."""
    if not path.is_file() or path.is_symlink():
        return False
    if _LEFT_BEHIND.fullmatch(path.name):
        return True
    if path.name == MANIFEST:
        return _manifest(path.parent.parent) is not None
    if path.name in (CHECKPOINT, STUDIES):
        try:
            read_arrays(path)
        except ForeignFiles:
            return False
        return True
    return path.suffix == ".parquet" and KEY in (_parquet_metadata(path) or {})


def _named(paths: list[Path], directory: Path) -> str:
    """Up to five paths relative to ``directory``, and how many more."""
    names = [str(p.relative_to(directory)) for p in sorted(paths)]
    return ", ".join(names[:5]) + (f" and {len(names) - 5} more" if len(names) > 5 else "")


def prepare_folder(directory: Path, key: str, chunks: int, source: str,
                   keep: str | None = None, overwrite: bool = False) -> set[Path]:
    """Make ``directory`` the folder of the run ``key`` (of ``chunks`` chunks, scenario file
    ``source``) and return the part files of that run already in it.

    A new run (``keep`` None) first deletes what earlier runs of this program left: the parts,
    the result files and the fragility plots; it refuses (``ForeignFiles``, naming them) where
    ``parts/`` or a result file's name holds a file this program did not write.  A run that
    keeps the parts (``keep``: the option that asks it, ``"--resume"`` or ``"--shard"``) refuses
    a folder whose parts or results belong to another run, manifest or not.  A new run refuses
    (``UnfinishedRun``) to delete the parts of a run that did not finish (parts or saved studies,
    no summary) unless ``overwrite``."""
    parts = directory / "parts"
    parts.mkdir(parents=True, exist_ok=True)
    results = [directory / name for name in RESULTS if (directory / name).exists()]
    if keep is None:
        entries = sorted(parts.iterdir())
        foreign = ([p for p in entries if not _written_in_parts(p)]
                   + [p for p in results if not _written_here(p)])
        if foreign:
            raise ForeignFiles(f"{directory}: holds files vines-stoch did not write "
                               f"({_named(foreign, directory)}); a run never reads or deletes them: move "
                               "them out of the folder, or use another --out folder")
        kept = [p for p in entries if p.name != MANIFEST]
        if kept and not overwrite and not (directory / "summary.parquet").exists():
            of = (_manifest(directory) or {}).get("source", "a run")
            raise UnfinishedRun(f"{directory}: holds {len(kept)} file(s) of work an unfinished run of {of} "
                                "kept (interrupted, or run in shards); run again with --resume to go on from "
                                "them (resume=True from Python), or with --overwrite to discard them "
                                "(overwrite=True)")
        plots = [p for suffix in ("png", "svg") for p in directory.glob(f"fragility_*.{suffix}")
                 if _written_here(p)]
        for path in entries + results + plots:
            path.unlink()
        mine = set()
    else:
        option = f"{keep}: "
        manifest = _manifest(directory)
        if manifest is None and (parts / MANIFEST).exists():
            raise ForeignFiles(f"{directory}: {option}parts/{MANIFEST} is not a manifest vines-stoch wrote; "
                               "move it out of the folder, or use another --out folder")
        if manifest is not None and manifest["key"] != key:
            raise _another_run(directory, option, keep,
                               f"its parts are those of {manifest.get('source', 'another run')}")
        mine, other = set(), []
        for path in parts.glob("point*.parquet"):
            meta = _parquet_metadata(path)
            if meta is None and _PART.fullmatch(path.name) and _starts_as_parquet(path):
                raise DamagedFile(f"{path}: damaged (a Parquet file that cannot be read: cut short by an "
                                  "interrupted copy or a full disk); delete it and run again with --resume "
                                  "(its chunk runs again)")
            found = (meta or {}).get(KEY)
            if found == key:
                mine.add(path)
            elif found is not None or _PART.fullmatch(path.name):
                other.append(path)
        if other:
            raise _another_run(directory, option, keep, f"{_named(other, directory)} belong to another run "
                               "or were not written by vines-stoch")
        other = [p for p in results if (_parquet_metadata(p) or {}).get(KEY) != key]
        if other:
            raise _another_run(directory, option, keep, f"{_named(other, directory)} belong to another run "
                               "or carry no run key")
    tmp = parts / f"{MANIFEST}.{os.getpid()}"  # (shards write it side by side)
    tmp.write_text(json.dumps({"key": key, "chunks": chunks, "source": source}))
    os.replace(tmp, parts / MANIFEST)
    return mine


def _another_run(directory: Path, option: str, keep: str, what: str) -> ForeignFiles:
    return ForeignFiles(f"{directory}: {option}{what} (a different scenario or chunk plan, or another "
                        "backend); finish that run with its own scenario file, "
                        + ("run without --resume to replace them, " if keep == "--resume" else "")
                        + "or use another --out folder")


def check_folder(directory: Path) -> str:
    """The run key of the results in ``directory``; ``ForeignFiles`` where a result file (or the
    parts' manifest) belongs to another run than ``summary.parquet`` or carries no run key,
    ``FileNotFoundError`` where there is no ``summary.parquet`` (saying so if an unfinished run
    is in ``parts/``)."""
    summary = directory / "summary.parquet"
    manifest = _manifest(directory)
    if not summary.is_file():
        unfinished = ""
        if manifest is not None:
            kept = len(list((directory / "parts").glob("point*.parquet")))
            unfinished = (f"; its parts hold an unfinished run of {manifest.get('source', 'a scenario')} "
                          f"({kept} of {manifest.get('chunks', '?')} chunks): finish it with "
                          f"vines-stoch run SCENARIO --out {directory} --resume")
        raise FileNotFoundError(f"{directory}: no summary.parquet (not a finished vines-stoch run)"
                                f"{unfinished}")
    key = None
    for name in RESULTS:
        path = directory / name
        if not path.exists():
            continue
        found = (_parquet_metadata(path) or {}).get(KEY)
        if found is None:
            raise ForeignFiles(f"{path}: carries no run key (written by another program or an earlier "
                               "version of vines-stoch), so it cannot be checked against its run: run the "
                               f"scenario again into {directory}, or remove {name}")
        if key is None:
            key = found
        elif found != key:
            raise ForeignFiles(f"{path}: belongs to another run than {summary} (the folder mixes two runs): "
                               f"run the scenario again into {directory}"
                               + (f", or remove {name}" if name == "fragility.parquet" else ""))
    if manifest is not None and manifest["key"] != key:
        raise ForeignFiles(f"{directory}: its results and its parts belong to two runs (parts of "
                           f"{manifest.get('source', 'another scenario')}): finish that run with --resume, "
                           "or run the results' scenario again into the folder")
    return key
