"""numba's on-disk cache of the kernels, keyed by the sources of the physics and the kernels.

numba checks a cached function against its own source file only: a kernel that inlines a
formula of ``physics/`` or ``kernels/common.py`` would load its stale machine code after that
formula was edited.  ``key_by_sources`` puts the cache of every compiled function of this
package in a folder named by a hash of all those sources (``vines-stoch-<hash>`` under the
package's ``__pycache__`` folders, or under ``NUMBA_CACHE_DIR`` where that is set), so an edit
anywhere in them compiles afresh, and going back to earlier sources finds their cache again.
Functions outside the package keep numba's own locations.  ``make clean-cache`` removes the
folders of earlier sources.  ``compile_once`` lets one process of a machine at a time compile a
loop, so that processes starting the same loop together compile it once, with the faster front
end (``frontend.compiling``).  ``cache_on_disk`` caches the cuda backend's launchers in the same
folders (numba-cuda's own ``cache=True`` would miss in every new process: see there).
"""

from __future__ import annotations

import hashlib
import importlib
import inspect
import os
import types
import warnings
from functools import cache
from pathlib import Path
from typing import Any

import numpy as np
from filelock import FileLock

from .flags import VECTOR_BITS

#: The package's folder.
PACKAGE = Path(__file__).resolve().parent.parent
#: The sources compiled functions are built from: the formulas, the step loops and what they
#: inline, the compiler settings, and the modules whose constants they read (the signal and
#: reduction codes of ``signals.py``, the stream purposes and the generators of ``streams/``).
SOURCES = ("physics", "jit", "outputs.py", "kernels", "signals.py", "streams")


def files_digest(root: Path, files: list[Path]) -> str:
    """A hash of ``files`` in the order given: each one's path relative to ``root``, then its
    bytes (hex digits; ``OSError`` where one cannot be read)."""
    h = hashlib.sha256()
    for f in files:
        h.update(str(f.relative_to(root)).encode())
        h.update(f.read_bytes())
    return h.hexdigest()


def digest(package: Path = PACKAGE) -> str | None:
    """A hash of the sources named by ``SOURCES`` (their paths and bytes) and of the vector
    width the lane loops ask for (``flags.VECTOR_BITS``), 16 hex digits; None where the sources
    are not files (a package imported from a zip archive)."""
    files = []
    for name in SOURCES:
        path = package / name
        files += sorted(path.glob("*.py")) if path.is_dir() else [path]
    try:
        sources = files_digest(package, files)
    except OSError:
        return None
    # the settings read from the environment that change the machine code (not the sources)
    return hashlib.sha256(f"{sources} vector-bits={VECTOR_BITS}".encode()).hexdigest()[:16]


def key_by_sources(package: str = "numba.core") -> str:
    """Make numba (``package``: ``numba.core``; numba-cuda's cache, ``numba.cuda.core``) cache
    this package's compiled functions in a folder named by ``digest`` (once); returns that
    folder's name ("" where the sources cannot be read: numba's own locations, and a zip
    archive cannot be edited anyway)."""
    caching = importlib.import_module(f"{package}.caching")
    config = importlib.import_module(f"{package}.config")
    key = digest()
    if key is None:
        return ""
    name = f"vines-stoch-{key}"
    locators = getattr(getattr(caching, "CacheImpl", None), "_locator_classes", None)
    mixin = getattr(caching, "_SourceFileBackedLocatorMixin", None)
    base = getattr(caching, "UserProvidedCacheLocator", getattr(caching, "_UserProvidedCacheLocator", None))
    if locators is None or mixin is None or base is None:  # another numba's cache internals: its own
        return ""
    if any(getattr(k, "keyed_by_sources", False) for k in locators):
        return name

    class SourceKeyedLocator(base):
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

        def get_source_stamp(self):
            """The folder's own key, the sources' digest, in place of numba's hash of the one
            source file read when the cache was opened: processes that read that file at
            different moments (an edit between two starts) would otherwise each find the other's
            index stale and rewrite it from its first data file's name on, over entries the other
            still lists (seen: a scene run on another structure's loop)."""
            return name

        @classmethod
        def from_function(cls, py_func, py_file):
            if not Path(py_file).resolve().is_relative_to(PACKAGE):
                return None
            # (a folder that cannot be written: numba's next locators, a user-wide cache)
            return mixin.from_function.__func__(cls, py_func, py_file)

    locators.insert(0, SourceKeyedLocator)
    _lock_saves(caching)
    return name


def _lock_saves(caching: Any) -> None:
    """Make numba's ``Cache.save_overload`` (of ``caching``, numba's or numba-cuda's module) save
    the entries of this package's functions (a cache folder ``key_by_sources`` names) under a
    lock on the function's index file, and not at all where the sources changed since this
    process keyed its folder; other functions' saves are numba's own.  Every signature of a
    function has its entry in one index, and numba names a new entry's data file after the
    entries of the index it has just read: two processes that compile two signatures of one
    function at once could read the same index and pick the same name, the later write
    winning, so that the other's entry would load the wrong machine code (seen: step loops of
    other structures; uncertain parameters run on another compile's draws, every realisation
    alike).  Where numba's cache has no ``save_overload``, its own saves stand and a warning says
    so."""
    base = getattr(caching, "Cache", None)
    original = getattr(base, "save_overload", None)
    if original is None:
        warnings.warn(f"vines_stoch.jit.cache: {caching.__name__}.Cache has no save_overload to lock; two "
                      "processes compiling one function at once could mix its entries", RuntimeWarning,
                      stacklevel=2)
        return
    if getattr(original, "locks_vines_stoch", False):
        return

    def save_overload(self: Any, sig: Any, data: Any) -> None:
        folder = os.path.basename(getattr(self, "_cache_path", ""))
        if not folder.startswith("vines-stoch-"):
            return original(self, sig, data)
        if folder != f"vines-stoch-{digest()}":
            # the sources changed since this process keyed its folder: what it compiled now is
            # not what that folder's sources give
            warnings.warn(f"vines_stoch.jit.cache: the package's sources changed since this process "
                          f"started; a function compiled now is not saved in {folder}", RuntimeWarning,
                          stacklevel=2)
            return None
        index = getattr(getattr(self, "_cache_file", None), "_index_path", None)
        if index is None:  # (another numba's internals: not saved, rather than saved unlocked)
            warnings.warn("vines_stoch.jit.cache: this numba's cache keeps no _cache_file._index_path to "
                          "lock; a function compiled now is not saved on disk (saved unlocked, two "
                          "processes could mix two signatures' entries)", RuntimeWarning, stacklevel=2)
            return None
        with FileLock(f"{index}.lock"):
            return original(self, sig, data)

    save_overload.locks_vines_stoch = True
    base.save_overload = save_overload


def _in_sources(func: Any) -> bool:
    """Whether the function ``func`` is defined in one of the files ``digest`` reads."""
    try:
        path = Path(inspect.getfile(func)).resolve().relative_to(PACKAGE)
    except (TypeError, ValueError):  # (built in, or outside the package)
        return False
    return path.parts[0] in SOURCES


def described(value: Any) -> str | None:
    """``value`` as a compile reads it, in words that are the same in every process: constants
    by ``repr``, tuples and lists item by item, a function or compiled function defined in the
    sources ``digest`` reads by its module, name, defaults and closure (and a compiled
    function's options); None for anything else (nothing that names it the same in each
    process)."""
    if value is None or isinstance(value, (bool, int, float, complex, str, bytes, np.generic)):
        return repr(value)
    if isinstance(value, (tuple, list)):
        items = [described(v) for v in value]
        return None if None in items else f"{type(value).__name__}({', '.join(items)})"
    func = getattr(value, "py_func", value)
    if not inspect.isfunction(func) or not _in_sources(func):
        return None
    inner = described((func.__defaults__ or (), tuple(c.cell_contents for c in func.__closure__ or ())))
    options = getattr(value, "targetoptions", None)
    if options is not None:
        options = sorted((k, sorted(v) if isinstance(v, (set, frozenset)) else v) for k, v in options.items())
    return None if inner is None else f"{func.__module__}.{func.__qualname__}: {inner} {options or ''}"


def compile_once(dispatcher: Any, args: tuple, package: str = "numba.core") -> None:
    """Compile ``dispatcher`` (a numba function cached on disk; ``package`` ``numba.cuda.core``:
    a numba-cuda kernel) for the types of ``args`` with the faster front end
    (``frontend.compiling``), or load it from the cache, one process of this machine at a time:
    processes that start the same loop together (the workers of an ensemble or of a test run)
    compile it once, the others wait for it and load it (a cold step loop takes 5-20 s to
    compile; two at once take as long each on separate cores, or twice as long on one).  The
    lock is a file beside the cache, named by a hash of the function, its closure and the
    argument types (``filelock.FileLock``); where the cache's folder cannot be written, it
    compiles unlocked."""
    from numba import typeof

    from . import frontend  # (on first use: the physics floor, built on this floor, never loads it)

    typer = typeof if package == "numba.core" else dispatcher.typeof_pyval
    signature = tuple(typer(a) for a in args)
    if signature in dispatcher.overloads:
        return
    func = dispatcher.py_func
    identity = described(dispatcher) or repr((func.__module__, func.__qualname__,
                                              tuple(cell.cell_contents for cell in func.__closure__ or ())))
    key = hashlib.sha256(repr((identity, signature)).encode()).hexdigest()
    # (the file lock first, then the compiler's: no thread holds the compiler's lock while it
    # waits for another process)
    try:
        folder = Path(dispatcher.stats.cache_path)
        folder.mkdir(parents=True, exist_ok=True)
        lock = FileLock(folder / f"compile-{key[:16]}.lock")
        lock.acquire()
    except (AttributeError, OSError, TypeError):  # (no cache folder to write)
        lock = None
    try:
        with frontend.compiling(package):
            dispatcher.compile(signature)
    finally:
        if lock is not None:
            lock.release()


@cache
def _stable_cache(gpu: bool) -> type:
    """numba's disk cache of compiled functions (numba-cuda's, of kernels, where ``gpu``), its
    entries keyed by ``described`` of the closure."""
    if gpu:
        from numba.cuda.dispatcher import CUDACache as base
    else:
        from numba.core.caching import FunctionCache as base

    class StableCache(base):
        """numba's cache whose index key (a hash of the function's bytecode and a pickle of its
        closure's contents) reads, in place of the closure's contents, their descriptions
        ``cells``; its entries saved one process at a time (``_lock_saves``)."""

        def __init__(self, py_func: Any, cells: list[str]) -> None:
            super().__init__(py_func)
            self._py_func = types.FunctionType(py_func.__code__, {}, py_func.__name__, None,
                                               tuple(types.CellType(c) for c in cells))

    return StableCache


def stable_cache(dispatcher: Any) -> bool:
    """Key the disk cache of ``dispatcher`` (a step loop of this package compiled with
    ``cache=True``) by ``described`` of its closure's contents in place of numba's pickle of
    them: the loop driver closes over its scheme's step functions (``kernels.driver``), whose
    dispatchers pickle with an identity drawn afresh in each process (numba's
    ``_MemoMixin._uuid``), so that no process would find another's entries (each would compile
    the loop again and add one).  The function also takes a name of its own, its qualified name
    and a hash of those descriptions: numba names a compiled function's symbol by its qualified
    name, its types and a counter of the compiling process, so that two loops of one closure
    (a loop recording first passages and one that does not), compiled by two processes with the
    same count, would share a symbol, and a process loading both (a chunk loop linking its step
    loop) would run the first one loaded in place of the other (seen: first passages missing
    from a sensitivity design that ran after another scene's ensemble).  Returns whether it is
    so keyed: not where a closure's content has no such description (numba's own key then
    stands, whose entries no other process finds)."""
    from numba.core.caching import FunctionCache

    func = dispatcher.py_func
    cells = [described(c.cell_contents) for c in func.__closure__ or ()]
    if None in cells or not isinstance(getattr(dispatcher, "_cache", None), FunctionCache):
        return False
    if not getattr(func, "named_by_closure", False):
        func.__qualname__ = f"{func.__qualname__}_{hashlib.sha256(repr(cells).encode()).hexdigest()[:16]}"
        func.named_by_closure = True
    dispatcher._cache = _stable_cache(False)(func, cells)
    return True


def cache_on_disk(dispatcher: Any) -> bool:
    """Cache ``dispatcher`` (a ``numba.cuda.jit`` kernel of this package, made without
    ``cache``) on disk as numba-cuda's ``cache=True`` does, in the folder ``key_by_sources``
    names, its entries keyed by ``described`` of its closure's contents in place of numba-cuda's
    pickle of them: a launcher closes over a step loop's dispatcher, which pickles with an
    identity drawn afresh in each process (numba's ``_MemoMixin._uuid``), so no process would
    find another's entries (and each would add one).  Returns whether it is cached: not where
    a closure's content has no such description, or the sources cannot be read."""
    func = dispatcher.py_func
    cells = [described(c.cell_contents) for c in func.__closure__ or ()]
    if None in cells or not key_by_sources("numba.cuda.core"):
        return False
    dispatcher._cache = _stable_cache(True)(func, cells)  # (as numba-cuda's ``enable_caching`` does)
    return True
