"""Where chunks run: dask's embedded threaded scheduler or a ``dask.distributed`` cluster.

Both take jobs in plan order, skip those ``skip(job)`` rules out when they come up, and hand
results back to the calling thread as they finish (``(job, result)``), with a bounded number
in flight so that memory does not grow with the number of chunks.
"""

from __future__ import annotations

import queue
import threading
from collections.abc import Callable, Iterable, Iterator
from typing import Any

import dask
import dask.threaded

Call = Callable[[Any], tuple[Callable[..., Any], tuple]]
_DONE = object()


def _next(pending: Iterator[Any], skip: Callable[[Any], bool]) -> Any:
    """The next job that ``skip`` does not rule out, or None."""
    for job in pending:
        if not skip(job):
            return job
    return None


def embedded(jobs: Iterable[Any], call: Call, skip: Callable[[Any], bool],
             workers: int) -> Iterator[tuple[Any, Any]]:
    """Run ``fn(*args)`` for ``(fn, args) = call(job)`` on dask's local threaded scheduler:
    ``workers`` loops take the jobs in order (kernels release the GIL)."""
    lock = threading.Lock()
    pending = iter(jobs)
    results: queue.Queue = queue.Queue(maxsize=2 * workers)
    stop = threading.Event()

    def put(item: Any) -> None:
        while not stop.is_set():
            try:
                results.put(item, timeout=0.1)
                return
            except queue.Full:
                continue

    def loop(_: int) -> None:
        while not stop.is_set():
            with lock:
                job = _next(pending, skip)
            if job is None:
                return
            fn, args = call(job)
            try:
                put((job, fn(*args), None))
            except BaseException as exc:  # handed to the calling thread
                put((job, None, exc))
                return

    def compute() -> None:
        # the threaded scheduler's function, not its name: given a name, dask imports
        # dask.distributed (0.27 s, the run's largest import) to look for a client
        dask.compute(*[dask.delayed(loop)(i) for i in range(workers)], scheduler=dask.threaded.get,
                     num_workers=workers)
        put(_DONE)

    threading.Thread(target=compute, daemon=True, name="vines-stoch-embedded").start()
    try:
        while (item := results.get()) is not _DONE:
            job, result, exc = item
            if exc is not None:
                raise exc
            yield job, result
    finally:
        stop.set()


def distributed(client: Any, jobs: Iterable[Any], call: Call,
                skip: Callable[[Any], bool]) -> Iterator[tuple[Any, Any]]:
    """Submit ``fn(*args)`` for ``(fn, args) = call(job)`` to a ``dask.distributed`` client,
    two jobs per worker thread in flight; jobs that ``skip`` rules out once running are
    cancelled.  A lost worker's jobs are rerun by the scheduler."""
    from dask.distributed import as_completed

    window = 2 * max(sum(client.nthreads().values()), 1) + 2
    pending = iter(jobs)
    running: dict[Any, Any] = {}
    completed = as_completed()

    def submit_more() -> None:
        while len(running) < window:
            job = _next(pending, skip)
            if job is None:
                return
            fn, args = call(job)
            future = client.submit(fn, *args, pure=False)
            running[future] = job
            completed.add(future)

    try:
        submit_more()
        for future in completed:
            job = running.pop(future, None)
            if job is None:  # cancelled
                continue
            yield job, future.result()
            for other, other_job in list(running.items()):
                if skip(other_job):
                    other.cancel()
                    running.pop(other)
            submit_more()
    finally:
        for future in running:
            future.cancel()
