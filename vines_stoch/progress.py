"""Progress of a run: a bar with rate and ETA on a terminal, plain lines in logs, and the total
time at the end."""

from __future__ import annotations

import sys
import time

#: Seconds between plain progress lines (non-terminal output).
LINE_EVERY = 10.0


def rate_text(done: int, seconds: float) -> str:
    """``done`` realisations in ``seconds`` as a rate that reads right at any speed: ``1,234/s``,
    ``3.52/s``, or below one a second the time each takes (``12.5 s each``); ``"measuring"``
    before the first is done."""
    if done <= 0 or seconds <= 0:
        return "measuring"
    rate = done / seconds
    if rate >= 100:
        return f"{rate:,.0f}/s"
    if rate >= 1:
        return f"{rate:.3g}/s"
    return f"{seconds / done:.3g} s each"


class Progress:
    """Realisations done out of ``total``, advanced per finished chunk, on standard error; on
    leaving without an error, one line with the realisations run, the time they took and their
    rate."""

    def __init__(self, total: int, done: int = 0, enabled: bool = True):
        self.total, self.done, self.first = total, done, done
        self.enabled = enabled and total > done
        self.tty = sys.stderr.isatty()
        self.start = self.last = time.monotonic()
        self._bar = None

    def __enter__(self) -> Progress:
        self.start = self.last = time.monotonic()
        if self.enabled and self.tty:
            from rich.progress import (
                BarColumn,
                MofNCompleteColumn,
                TextColumn,
                TimeElapsedColumn,
                TimeRemainingColumn,
            )
            from rich.progress import Progress as Bar

            self._bar = Bar(TextColumn("realisations"), BarColumn(), MofNCompleteColumn(),
                            TextColumn("{task.fields[rate]}"), TimeElapsedColumn(), TextColumn("eta"),
                            TimeRemainingColumn(), transient=False, redirect_stdout=False)
            self._bar.__enter__()
            self._task = self._bar.add_task("run", total=self.total, completed=self.done,
                                            rate=rate_text(0, 0.0))
        return self

    def advance(self, count: int) -> None:
        """``count`` more realisations are done."""
        self.done += count
        if not self.enabled:
            return
        now = time.monotonic()
        rate = rate_text(self.done - self.first, now - self.start)
        if self._bar is not None:
            self._bar.update(self._task, completed=self.done, rate=rate)
        elif now - self.last >= LINE_EVERY or self.done >= self.total:
            self.last = now
            per_second = (self.done - self.first) / max(now - self.start, 1e-9)
            eta = f"{(self.total - self.done) / per_second:.0f} s" if per_second > 0 else "unknown"
            print(f"realisations {self.done}/{self.total} ({100 * self.done / self.total:.0f} %)  "
                  f"{rate}  eta {eta}", file=sys.stderr, flush=True)

    def __exit__(self, kind: type | None, *exc: object) -> None:
        if self._bar is not None:
            self._bar.__exit__(kind, *exc)
        if self.enabled and kind is None:
            seconds = time.monotonic() - self.start
            ran = self.done - self.first
            print(f"done: {ran} realisation(s) in {seconds:.1f} s ({rate_text(ran, seconds)})",
                  file=sys.stderr, flush=True)
