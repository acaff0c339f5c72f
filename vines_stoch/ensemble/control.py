"""Control of a running ensemble: Ctrl-C noted and reported with what is kept, and the
connection to a ``dask.distributed`` cluster."""

from __future__ import annotations

import json
import signal
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path


class Interrupted(KeyboardInterrupt):
    """A run stopped by Ctrl-C: ``kept`` of its ``total`` chunks are in its folder for ``--resume``."""

    def __init__(self, kept: int, total: int):
        super().__init__(f"interrupted: {kept} of {total} chunks kept; finish with --resume")
        self.kept, self.total = kept, total


@contextmanager
def noting_interrupts() -> Iterator[threading.Event]:
    """While a run in the main thread runs its chunks: Ctrl-C raises ``KeyboardInterrupt`` as
    always and is also noted in the event yielded, so that one lost on its way (raised inside a
    finaliser or a library's broad handler, where it is dropped) still stops the run.  Elsewhere
    (another thread; SIGINT handled or ignored by the caller) the event stays clear."""
    noted = threading.Event()
    if (threading.current_thread() is not threading.main_thread()
            or signal.getsignal(signal.SIGINT) is not signal.default_int_handler):
        yield noted
        return

    def note(signum: int, frame: object) -> None:
        noted.set()
        signal.default_int_handler(signum, frame)

    signal.signal(signal.SIGINT, note)
    try:
        yield noted
    finally:
        signal.signal(signal.SIGINT, signal.default_int_handler)


@contextmanager
def client(scheduler: str, announce: bool = False) -> Iterator[object]:
    """A ``dask.distributed`` client connected to ``scheduler``: an address, or the path of a
    scheduler file (the JSON ``dask scheduler --scheduler-file`` writes); with ``announce``,
    the dashboard's address goes to standard error."""
    from dask.distributed import Client

    by_file = "://" not in scheduler and Path(scheduler).is_file()
    if by_file:
        try:
            address = json.loads(Path(scheduler).read_text(errors="replace")).get("address")
        except (ValueError, AttributeError, OSError):
            address = None
        if not isinstance(address, str):
            raise ValueError(f"--scheduler-file {scheduler}: not a dask scheduler file (the JSON with an "
                             "'address' that dask scheduler --scheduler-file FILE writes)")
    try:
        client = (Client(scheduler_file=scheduler, timeout="30s") if by_file
                  else Client(scheduler, timeout="30s"))
    except (OSError, TimeoutError, ValueError, KeyError) as exc:
        raise ValueError(f"{'--scheduler-file' if by_file else '--scheduler'} {scheduler}: {exc}") from None
    with client:
        if announce:
            print(f"dask.distributed at {client.scheduler.address}, dashboard {client.dashboard_link}",
                  file=sys.stderr)
        yield client
