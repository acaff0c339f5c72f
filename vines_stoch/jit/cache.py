"""numba's on-disk cache of the kernels, keyed by the sources of the physics and the kernels.

numba checks a cached function against its own source file only: a kernel that inlines a
formula of ``physics/`` or ``kernels/common.py`` would load its stale machine code after that
formula was edited.  The package's functions are compiled by ``njit`` (numba's, with the disk
cache ``package_cache``: a subclass of numba's, set on each of them as numba's own
``cache=True`` sets its cache), which keeps them in a folder named by a hash of all those
sources (``vines-stoch-<hash>`` under the package's ``__pycache__`` folders, or under
``NUMBA_CACHE_DIR`` where that is set), so an edit anywhere in them compiles afresh, and going
back to earlier sources finds their cache again.  numba's own classes are not changed: other
code of the process caches as numba does.  ``make clean-cache`` removes the folders of earlier
sources.  ``compile_once`` lets one process of a machine at a time compile a loop, so that
processes starting the same loop together compile it once, with the faster front end
(``frontend.compiling``); ``compiling_nothing`` lets a caller load a loop from the disk cache or
learn that it is not there, compiling nothing.  ``cache_on_disk`` caches the cuda backend's
launchers in the same folders (numba-cuda's own ``cache=True`` would miss in every new process:
see there).
"""

from __future__ import annotations

import hashlib
import importlib
import inspect
import os
import threading
import types
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
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


def cache_folder() -> str:
    """The folder, under the package's ``__pycache__`` folders or ``NUMBA_CACHE_DIR``, that holds
    the compiled functions of these sources: ``vines-stoch-<digest>`` ("" where the sources
    cannot be read: numba's own locations, and a zip archive cannot be edited anyway)."""
    key = digest()
    return "" if key is None else f"vines-stoch-{key}"


def _source_keyed_locator(package: str, name: str) -> type | None:
    """numba's cache locator (of ``package``: ``numba.core``, or numba-cuda's ``numba.cuda.core``)
    of the folder ``name``; None where that numba has other cache internals (its own locations
    then stand)."""
    caching = importlib.import_module(f"{package}.caching")
    config = importlib.import_module(f"{package}.config")
    mixin = getattr(caching, "_SourceFileBackedLocatorMixin", None)
    base = getattr(caching, "UserProvidedCacheLocator", getattr(caching, "_UserProvidedCacheLocator", None))
    if mixin is None or base is None:
        return None

    class SourceKeyedLocator(base):
        """The cache of a function of this package: ``name`` under ``NUMBA_CACHE_DIR`` (with
        numba's own sub-path of the file's folder) or under the file's ``__pycache__``."""

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

    return SourceKeyedLocator


@cache
def package_cache(gpu: bool = False) -> type:
    """numba's disk cache of compiled functions (numba-cuda's, of kernels, where ``gpu``) as this
    package's functions use it (``njit``, ``stable_cache``, ``cache_on_disk``): a subclass, so
    numba's own classes stay as they are and other code of the process caches as numba does.

    * Its folder is ``cache_folder``'s: an edit of any source that ``digest`` reads compiles
      afresh, and going back to earlier sources finds their cache again.
    * Its entries are saved one process at a time, under a lock on the function's index, and
      not at all where the sources changed since this process started.  Every signature of a
      function has its entry in one index, and numba names a new entry's data file after the
      entries of the index it has just read: two processes that compile two signatures of one
      function at once could read the same index and pick the same name, the later write
      winning, so that the other's entry would load the wrong machine code (seen: step loops of
      other structures; uncertain parameters run on another compile's draws, every realisation
      alike).

    numba's own class where the sources cannot be read, or where that numba's cache internals
    differ (then a warning says so once)."""
    if gpu:
        from numba.cuda.dispatcher import CUDACache as base
    else:
        from numba.core.caching import FunctionCache as base
    name = cache_folder()
    locator = _source_keyed_locator("numba.cuda.core" if gpu else "numba.core", name) if name else None
    impl = getattr(base, "_impl_class", None)
    if locator is None or impl is None or not hasattr(impl, "_locator_classes"):
        if name:
            warnings.warn(f"vines_stoch.jit.cache: this numba's cache ({base.__module__}) is not the one "
                          "the package was written for; its functions cache in numba's own folders, not "
                          "keyed by the package's sources", RuntimeWarning, stacklevel=2)
        return base

    class PackageCacheImpl(impl):
        _locator_classes = [locator, *impl._locator_classes]

    class PackageCache(base):
        _impl_class = PackageCacheImpl

        def save_overload(self, sig: Any, data: Any) -> None:
            folder = os.path.basename(getattr(self, "_cache_path", ""))
            if folder != cache_folder():
                # the sources changed since this process keyed its folder: what it compiled now is
                # not what that folder's sources give (or numba's next locator took the function)
                if folder.startswith("vines-stoch-"):
                    warnings.warn(f"vines_stoch.jit.cache: the package's sources changed since this "
                                  f"process started; a function compiled now is not saved in {folder}",
                                  RuntimeWarning, stacklevel=2)
                    return None
                return super().save_overload(sig, data)
            with FileLock(f"{self._cache_file._index_path}.lock"):
                return super().save_overload(sig, data)

    return PackageCache


def njit(func: Any = None, **options: Any) -> Any:
    """``numba.njit`` for this package's functions: with ``cache=True`` they cache on disk in
    ``package_cache`` (``@njit(**flags.KERNEL)``, ``@njit(**flags.INLINE)``)."""
    import numba

    def compiled(f: Any) -> Any:
        dispatcher = numba.njit(**{**options, "cache": False})(f)
        if options.get("cache"):
            dispatcher._cache = package_cache(False)(f)  # (as numba's ``enable_caching`` sets its own)
        return dispatcher

    return compiled if func is None else compiled(func)


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


class NotCompiled(Exception):
    """A compile that ``compiling_nothing`` stopped: the loop is compiled neither in this process
    nor in the cache on disk for the types it was given."""


#: This thread's ``compiling_nothing`` depth and the loop ``compile_once`` looks for inside it.
_LOCAL = threading.local()


def refusing() -> bool:
    """Whether this thread is inside ``compiling_nothing``."""
    return getattr(_LOCAL, "depth", 0) > 0


@cache
def _listen() -> None:
    """Register, once a process, the listener to numba's ``numba:compile`` event that stops the
    compile of the loop ``compile_once`` looks for inside ``compiling_nothing`` (numba's event
    API; registered for good, so that no thread's compile walks the listeners while another
    thread takes its own away)."""
    from numba.core.event import Listener, register

    class Refusal(Listener):
        def on_start(self, event: Any) -> None:
            target = getattr(_LOCAL, "target", None)
            if target is not None and event.data["dispatcher"] is target:
                raise NotCompiled(f"{target} is not compiled for {event.data['args']}")

        def on_end(self, event: Any) -> None:
            pass

    register("numba:compile", Refusal())


@contextmanager
def compiling_nothing() -> Iterator[None]:
    """Inside the block, ``compile_once`` compiles nothing in this thread: a loop neither compiled
    in this process nor in the cache on disk raises ``NotCompiled`` before anything of it is
    compiled (at numba's ``numba:compile`` event, which a compile raises after looking in the
    cache on disk, so that a loop found there is loaded as ever).  Other threads, and the small
    functions a call compiles on the way (not through ``compile_once``), compile as ever.  It
    listens through numba's event API and changes nothing of numba."""
    _listen()
    _LOCAL.depth = getattr(_LOCAL, "depth", 0) + 1
    try:
        yield
    finally:
        _LOCAL.depth -= 1


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
    if refusing():  # (``compiling_nothing``: load it from the disk cache, or stop; no lock to wait on)
        _LOCAL.target = dispatcher
        try:
            dispatcher.compile(signature)
        finally:
            _LOCAL.target = None
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
    """The package's disk cache of compiled functions (``package_cache``; numba-cuda's, of
    kernels, where ``gpu``), its entries keyed by ``described`` of the closure."""

    class StableCache(package_cache(gpu)):
        """The package's cache whose index key (a hash of the function's bytecode and a pickle of
        its closure's contents) reads, in place of the closure's contents, their descriptions
        ``cells``."""

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
    if None in cells or not cache_folder():
        return False
    dispatcher._cache = _stable_cache(True)(func, cells)  # (as numba-cuda's ``enable_caching`` does)
    return True
