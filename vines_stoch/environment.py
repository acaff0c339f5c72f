"""The environment variables the package and numba read, checked before either uses them: a
mistake there is a clear error naming the variable and what it takes, not an internal error.
(Nothing here imports numba: numba reads ``NUMBA_NUM_THREADS`` when it is first imported.)"""

from __future__ import annotations

import os
from collections.abc import Callable

#: The environment variable that sets the vector width the lane loops ask for
#: (``jit.flags.VECTOR_BITS``), and the widths it may take (bits).
VECTOR_SWITCH = "VINES_STOCH_VECTOR_BITS"
VECTOR_CHOICES = (128, 256, 512)


def vector_problem() -> str | None:
    """Why ``VINES_STOCH_VECTOR_BITS`` cannot be used (None: unset, or a width it takes)."""
    bits = os.environ.get(VECTOR_SWITCH)
    if bits is None or bits.strip() in {str(b) for b in VECTOR_CHOICES}:
        return None
    return (f"environment variable {VECTOR_SWITCH}={bits!r}: give the vector width in bits, one of "
            f"{', '.join(map(str, VECTOR_CHOICES))}")


#: Runs of fewer path-steps than this (realisations times steps, every sweep point together) take
#: the general loop of their scheme, compiled once for every structure; longer ones a loop
#: specialised to their structure (``kernels.paths.general_run``), unless the environment
#: variable ``GENERAL_SWITCH`` sets another threshold.  The two loops give the same numbers.
GENERAL_WORK = 100_000_000
GENERAL_SWITCH = "VINES_STOCH_GENERAL_WORK"


def general_work() -> float | None:
    """The path-steps below which a run takes the general loops: ``VINES_STOCH_GENERAL_WORK``
    where set (a number >= 0; ``inf``: every run, 0: none), else ``GENERAL_WORK`` (None: the
    variable holds no such number)."""
    return _number(GENERAL_SWITCH, GENERAL_WORK, lambda work: work >= 0)


def _number(name: str, default: float, allowed: Callable[[float], bool]) -> float | None:
    """The number the environment variable ``name`` holds, ``default`` where it is unset (None:
    it holds no number ``allowed`` takes)."""
    text = os.environ.get(name)
    if text is None:
        return default
    try:
        value = float(text)
    except ValueError:
        return None
    return value if allowed(value) else None


def general_problem() -> str | None:
    """Why ``VINES_STOCH_GENERAL_WORK`` cannot be used (None: unset, or a number it takes)."""
    if general_work() is not None:
        return None
    return (f"environment variable {GENERAL_SWITCH}={os.environ[GENERAL_SWITCH]!r}: the path-steps below "
            f"which a run takes the general loops, a number >= 0 (default {GENERAL_WORK:.0e}; inf: every "
            "run, 0: none)")


def problems() -> list[str]:
    """One line for each environment variable set to what it cannot take:
    ``VINES_STOCH_VECTOR_BITS`` (``vector_problem``), ``VINES_STOCH_MEMORY_SHARE`` (a share
    above 0), ``VINES_STOCH_GENERAL_WORK`` (path-steps, a number >= 0) and ``NUMBA_NUM_THREADS``
    (numba's threads, a whole number >= 1)."""
    found = [why for why in (vector_problem(), general_problem()) if why]
    if memory_share() is None:
        found.append(f"environment variable {MEMORY_SWITCH}={os.environ[MEMORY_SWITCH]!r}: the share of this "
                     "machine's memory a study may plan to keep, a number > 0 (default "
                     f"{MEMORY_SHARE:g}; above 1 counts on swap)")
    threads = os.environ.get("NUMBA_NUM_THREADS")
    if threads is not None and not (threads.strip().isdigit() and int(threads) >= 1):
        found.append(f"environment variable NUMBA_NUM_THREADS={threads!r}: numba's threads, a whole number "
                     ">= 1 (unset it to use every core)")
    return found


def check() -> None:
    """``ValueError`` with every line of ``problems`` (none: nothing)."""
    found = problems()
    if found:
        raise ValueError("; ".join(found))


def physical_memory() -> int:
    """The machine's memory in bytes (0 where the system does not say)."""
    try:
        return int(os.sysconf("SC_PHYS_PAGES")) * int(os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):
        return 0


#: The share of the machine's memory a study may plan to keep (paths, bootstrap arrays), unless
#: the environment variable ``MEMORY_SWITCH`` sets another.
MEMORY_SHARE = 0.8
MEMORY_SWITCH = "VINES_STOCH_MEMORY_SHARE"


def memory_share() -> float | None:
    """The share of memory a study may plan to keep: ``VINES_STOCH_MEMORY_SHARE`` where set, else
    ``MEMORY_SHARE`` (None: the variable holds no number > 0)."""
    return _number(MEMORY_SWITCH, MEMORY_SHARE, lambda share: 0 < share < float("inf"))


def memory_problem(what: str, need: float) -> str | None:
    """Why ``need`` bytes of ``what`` cannot fit (None: they fit, or the memory is unknown)."""
    have, share = physical_memory(), memory_share() or MEMORY_SHARE
    if have and need > share * have:
        return (f"{what} would take about {need / 2**30:.3g} GiB, past {100 * share:.0f} % of this "
                f"machine's {have / 2**30:.3g} GiB (the environment variable {MEMORY_SWITCH} sets that "
                "share)")
    return None


class MissingExtra(ImportError):
    """An optional dependency a request needs is not installed: the message names the extra."""


#: How to install what a run on a dask.distributed cluster needs.
CLUSTER_EXTRA = "pip install 'vines-stoch[cluster]' (or .venv/bin/pip install -e '.[cluster]' in a checkout)"


def require_cluster(scheduler: str) -> None:
    """``MissingExtra`` where dask.distributed, which a run on ``scheduler`` needs, is not
    installed (the ``cluster`` extra), checked before anything is written."""
    import importlib.util

    try:
        found = importlib.util.find_spec("dask.distributed") is not None
    except (ImportError, ValueError):  # (a module set to None in sys.modules)
        found = False
    if not found:
        raise MissingExtra(f"scheduler {scheduler}: a dask.distributed cluster needs the cluster extra: "
                           f"{CLUSTER_EXTRA}")
