"""Reading a text file the user named (a scenario, a record) with one clear error for everything
that is not a readable UTF-8 text file: a missing file, a folder, a named pipe or a device, a
symbolic-link loop, a path holding a NUL byte, a file too large, binary content, another
encoding.  Messages name the file and what is wrong, and never quote its content.
"""

from __future__ import annotations

import codecs
import errno
import os
import stat
from pathlib import Path


class TextFileError(ValueError):
    """A file that cannot be read as text; the message names the file and the reason."""


#: Byte-order marks of encodings other than UTF-8 (UTF-32 first: its LE mark starts with UTF-16's).
_MARKS = ((codecs.BOM_UTF32_LE, "UTF-32"), (codecs.BOM_UTF32_BE, "UTF-32"),
          (codecs.BOM_UTF16_LE, "UTF-16"), (codecs.BOM_UTF16_BE, "UTF-16"))

_KINDS = ((stat.S_ISDIR, "a folder"), (stat.S_ISFIFO, "a named pipe"), (stat.S_ISCHR, "a device"),
          (stat.S_ISBLK, "a device"), (stat.S_ISSOCK, "a socket"))


def _status(path: Path) -> os.stat_result:
    try:
        return os.stat(path)
    except ValueError:  # an embedded NUL byte
        raise TextFileError(f"{ascii(str(path))}: the path holds a NUL byte") from None
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            raise TextFileError(f"{path}: a loop of symbolic links") from None
        if exc.errno == errno.ENOENT:
            raise TextFileError(f"{path}: no such file") from None
        raise TextFileError(f"{path}: cannot read ({exc.strerror})") from None


def _line(data: bytes, offset: int) -> int:
    """Line number (from 1) of byte ``offset``."""
    return data.count(b"\n", 0, offset) + 1


def read_text(path: str | Path, limit: int) -> str:
    """The content of the regular file ``path`` as text (UTF-8, an optional UTF-8 byte-order
    mark dropped), at most ``limit`` bytes; TextFileError otherwise."""
    path = Path(path)
    info = _status(path)
    for test, kind in _KINDS:
        if test(info.st_mode):
            raise TextFileError(f"{path}: is {kind}, not a file")
    if info.st_size > limit:
        raise TextFileError(f"{path}: {info.st_size} bytes; a file here may hold at most {limit} bytes")
    try:
        with open(path, "rb") as stream:
            data = stream.read(limit + 1)
    except OSError as exc:
        raise TextFileError(f"{path}: cannot read ({exc.strerror})") from None
    if len(data) > limit:
        raise TextFileError(f"{path}: more than {limit} bytes; a file here may hold at most {limit} bytes")
    for mark, name in _MARKS:
        if data.startswith(mark):
            raise TextFileError(f"{path}: {name} text; save it as UTF-8")
    data = data.removeprefix(codecs.BOM_UTF8)
    nul = data.find(b"\x00")
    if nul >= 0:
        raise TextFileError(f"{path}: a NUL byte at line {_line(data, nul)}: binary data or UTF-16 text, "
                            "not UTF-8 text")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = _line(data, exc.start)
        raise TextFileError(f"{path}: line {line}: byte 0x{data[exc.start]:02X} is not UTF-8; "
                            "save the file as UTF-8") from None
