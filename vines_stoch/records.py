"""Acceleration and force records: PEER NGA ``.AT2`` files, two columns ``t a``, or one column
with a given ``dt`` (MODEL.md section 3).

Every reading error names the file and, where there is one, the line.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from .textfile import TextFileError, read_text

#: Standard gravity, for records in units of g.
G = 9.80665

FORMATS = ("auto", "at2", "two-column", "one-column")

_NPTS = re.compile(r"NPTS\s*=?\s*([-+0-9.eE]+)", re.IGNORECASE)
_DT = re.compile(r"\bDT\s*=?\s*([-+0-9.eE]+)", re.IGNORECASE)
#: Older AT2 header line: ``4000   0.0100   NPTS, DT, ...``
_OLD_HEADER = re.compile(r"^\s*(\d+)\s+([-+0-9.eE]+)\s+NPTS", re.IGNORECASE)


#: The largest record file read (bytes).
RECORD_BYTES = 256 * 2**20


class RecordError(ValueError):
    """A record file that cannot be read; the message names the file and line, never its content."""


def _token(text: str) -> str:
    """The offending token as named in a message: by its length alone (the path may name any
    file, whose content is never echoed)."""
    return f"a {len(text)}-character token"


def _number(text: str, path: Path, line: int) -> float:
    try:
        value = float(text)
    except ValueError:
        raise RecordError(f"{path}: line {line}: {_token(text)} is not a number") from None
    if not np.isfinite(value):
        raise RecordError(f"{path}: line {line}: {_token(text)} is not a finite number")
    return value


def _at2_header(lines: list[str], path: Path) -> tuple[int, float, int] | None:
    """``(npts, dt, first data line index)`` of an AT2 header, or None if there is none."""
    for k, line in enumerate(lines[:8]):
        old = _OLD_HEADER.match(line)
        if old:
            return int(old.group(1)), _number(old.group(2), path, k + 1), k + 1
        npts, dt = _NPTS.search(line), _DT.search(line)
        if npts and dt:
            n = _number(npts.group(1).rstrip(",."), path, k + 1)
            if n != int(n):
                raise RecordError(f"{path}: line {k + 1}: NPTS is not a whole number")
            return int(n), _number(dt.group(1).rstrip(","), path, k + 1), k + 1
    return None


def read_record(path: str | Path, fmt: str = "auto",
                dt: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Times and values of a record file, in the file's own units.

    ``fmt``: ``at2`` (PEER NGA: four header lines, ``NPTS`` and ``DT`` on the fourth, values
    row by row), ``two-column`` (``t a`` per line), ``one-column`` (one value per line, needs
    ``dt``) or ``auto`` (AT2 when the header names NPTS and DT, else by the column count).
    Blank lines and lines starting with ``#`` are skipped in column files.
    """
    path = Path(path)
    if fmt not in FORMATS:
        raise RecordError(f"{path}: format {fmt!r}: must be one of {', '.join(FORMATS)}")
    try:
        lines = read_text(path, RECORD_BYTES).splitlines()
    except TextFileError as exc:
        raise RecordError(str(exc)) from None
    header = _at2_header(lines, path) if fmt in ("auto", "at2") else None
    if fmt == "at2" and header is None:
        raise RecordError(f"{path}: no AT2 header with NPTS and DT in the first lines")
    if header is not None:
        npts, step, first = header
        if dt is not None and dt != step:
            raise RecordError(f"{path}: the header says DT = {step:g}, the scenario dt = {dt:g}; give one")
        if step <= 0:
            raise RecordError(f"{path}: line {first}: DT = {step:g}: must be > 0")
        if npts < 1:
            raise RecordError(f"{path}: line {first}: NPTS = {npts}: must be >= 1")
        values = [_number(tok, path, k + 1) for k in range(first, len(lines)) for tok in lines[k].split()]
        if len(values) != npts:
            raise RecordError(f"{path}: the header says NPTS = {npts}, the file has {len(values)} values")
        return step * np.arange(npts), np.array(values)
    rows = [(k + 1, line.split()) for k, line in enumerate(lines)
            if line.strip() and not line.lstrip().startswith("#")]
    if not rows:
        raise RecordError(f"{path}: no data")
    width = 2 if fmt == "two-column" else 1 if fmt == "one-column" else len(rows[0][1])
    if width not in (1, 2):
        raise RecordError(f"{path}: line {rows[0][0]}: {len(rows[0][1])} columns; "
                          "expected 1 (values) or 2 (t a)")
    table = np.empty((len(rows), width))
    for r, (line, tokens) in enumerate(rows):
        if len(tokens) != width:
            raise RecordError(f"{path}: line {line}: {len(tokens)} columns; expected {width}")
        table[r] = [_number(tok, path, line) for tok in tokens]
    if width == 1:
        if dt is None:
            raise RecordError(f"{path}: one value per line: the scenario must give dt")
        return dt * np.arange(len(rows)), table[:, 0]
    if dt is not None:
        raise RecordError(f"{path}: the file has a time column; do not give dt")
    times = table[:, 0]
    steps = np.diff(times)
    if np.any(steps <= 0):
        bad = int(np.argmax(steps <= 0)) + 1
        raise RecordError(f"{path}: line {rows[bad][0]}: time {times[bad]:g} does not increase")
    return times, table[:, 1]


def write_at2(path: str | Path, dt: float, values: np.ndarray, title: str, units: str = "G") -> Path:
    """Write a PEER NGA style ``.AT2`` file (four header lines, five values per row)."""
    path = Path(path)
    rows = [" ".join(f"{v: .7E}" for v in values[k:k + 5]) for k in range(0, len(values), 5)]
    header = ["vines_stoch synthetic record", title, f"ACCELERATION TIME SERIES IN UNITS OF {units}",
              f"NPTS={len(values):8d}, DT={dt:10.4f} SEC"]
    path.write_text("\n".join(header + rows) + "\n")
    return path
