"""numba's on-disk cache of the kernels, keyed by the sources of the physics and the kernels.

numba checks a cached function against its own source file only: a kernel that inlines a
formula of ``physics/`` or ``kernels/common.py`` would load its stale machine code after that
formula was edited.  ``key_by_sources`` puts the cache of every compiled function of this
package in a folder named by a hash of all those sources (``vines-stoch-<hash>`` under the
package's ``__pycache__`` folders, or under ``NUMBA_CACHE_DIR`` where that is set), so an edit
anywhere in them compiles afresh, and going back to earlier sources finds their cache again.
Functions outside the package keep numba's own locations.  ``make clean-cache`` removes the
folders of earlier sources.  ``compile_once`` lets one process of a machine at a time compile a
loop, so that processes starting the same loop together compile it once.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path
from typing import Any

try:
    import fcntl
except ImportError:  # (no POSIX file locks: each process compiles on its own)
    fcntl = None

#: The package's folder.
PACKAGE = Path(__file__).resolve().parent.parent
#: The sources compiled functions are built from: the formulas, the step loops and what they
#: inline, and the compiler settings.
SOURCES = ("physics", "jit", "outputs.py", "kernels")


def files_digest(root: Path, files: list[Path]) -> str:
    """A hash of ``files`` in the order given: each one's path relative to ``root``, then its
    bytes (hex digits; ``OSError`` where one cannot be read)."""
    h = hashlib.sha256()
    for f in files:
        h.update(str(f.relative_to(root)).encode())
        h.update(f.read_bytes())
    return h.hexdigest()


def digest(package: Path = PACKAGE) -> str | None:
    """A hash of the sources named by ``SOURCES`` (their paths and bytes), 16 hex digits; None
    where they are not files (a package imported from a zip archive)."""
    files = []
    for name in SOURCES:
        path = package / name
        files += sorted(path.glob("*.py")) if path.is_dir() else [path]
    try:
        return files_digest(package, files)[:16]
    except OSError:
        return None


def key_by_sources() -> str:
    """Make numba cache this package's compiled functions in a folder named by ``digest``
    (once); returns that folder's name ("" where the sources cannot be read: numba's own
    locations, and a zip archive cannot be edited anyway)."""
    from numba.core import caching, config

    key = digest()
    if key is None:
        return ""
    name = f"vines-stoch-{key}"
    locators = getattr(getattr(caching, "CacheImpl", None), "_locator_classes", None)
    mixin = getattr(caching, "_SourceFileBackedLocatorMixin", None)
    if locators is None or mixin is None:  # another numba's cache internals: its own locations
        return ""
    if any(getattr(k, "keyed_by_sources", False) for k in locators):
        return name

    class SourceKeyedLocator(caching.UserProvidedCacheLocator):
        """The cache of a function of this package: ``name`` under ``NUMBA_CACHE_DIR`` (with
        numba's own sub-path of the file's folder) or under the file's ``__pycache__``."""

        keyed_by_sources = True

        def __init__(self, py_func, py_file):
            self._py_file = py_file
            self._lineno = py_func.__code__.co_firstlineno
            if config.CACHE_DIR:
                root = os.path.join(config.CACHE_DIR, self.get_suitable_cache_subpath(py_file))
            else:
                root = os.path.join(os.path.dirname(py_file), "__pycache__")
            self._cache_path = os.path.join(root, name)

        @classmethod
        def from_function(cls, py_func, py_file):
            if not Path(py_file).resolve().is_relative_to(PACKAGE):
                return None
            # (a folder that cannot be written: numba's next locators, a user-wide cache)
            return mixin.from_function.__func__(cls, py_func, py_file)

    locators.insert(0, SourceKeyedLocator)
    return name


def compile_once(dispatcher: Any, args: tuple) -> None:
    """Compile ``dispatcher`` (a numba function cached on disk) for the types of ``args``, or load
    it from the cache, one process of this machine at a time: processes that start the same
    loop together (the workers of an ensemble or of a test run) compile it once, the others wait
    for it and load it (a cold step loop takes 5-20 s to compile; two at once take as long
    each on separate cores, or twice as long on one).  The lock is a file beside the cache,
    named by a hash of the function, its closure and the argument types; where the cache's
    folder cannot be written, or there are no POSIX file locks, it compiles unlocked."""
    from numba import typeof

    signature = tuple(typeof(a) for a in args)
    if signature in dispatcher.overloads:
        return
    func = dispatcher.py_func
    closure = tuple(cell.cell_contents for cell in func.__closure__ or ())
    key = hashlib.sha256(repr((func.__module__, func.__qualname__, closure, signature)).encode()).hexdigest()
    handle = None
    if fcntl is not None:
        try:
            folder = Path(dispatcher.stats.cache_path)
            folder.mkdir(parents=True, exist_ok=True)
            handle = open(folder / f"compile-{key[:16]}.lock", "a")
        except (AttributeError, OSError, TypeError):  # (no cache folder to write)
            pass
    if handle is None:
        dispatcher.compile(signature)
        return
    with handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            dispatcher.compile(signature)
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)
