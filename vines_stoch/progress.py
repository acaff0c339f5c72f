"""Progress of a run: a bar with rate and ETA on a terminal, plain lines in logs."""

from __future__ import annotations

import sys
import time

#: Seconds between plain progress lines (non-terminal output).
LINE_EVERY = 10.0


class Progress:
    """Realisations done out of ``total``, advanced per finished chunk, on standard error."""

    def __init__(self, total: int, done: int = 0, enabled: bool = True):
        self.total, self.done, self.first = total, done, done
        self.enabled = enabled and total > done
        self.tty = sys.stderr.isatty()
        self.start = self.last = time.monotonic()
        self._bar = None

    def __enter__(self) -> Progress:
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
            self._task = self._bar.add_task("run", total=self.total, completed=self.done, rate="")
        return self

    def advance(self, count: int) -> None:
        """``count`` more realisations are done."""
        self.done += count
        if not self.enabled:
            return
        now = time.monotonic()
        rate = (self.done - self.first) / max(now - self.start, 1e-9)
        if self._bar is not None:
            self._bar.update(self._task, completed=self.done, rate=f"{rate:,.0f}/s")
        elif now - self.last >= LINE_EVERY or self.done >= self.total:
            self.last = now
            eta = (self.total - self.done) / rate if rate > 0 else float("inf")
            print(f"realisations {self.done}/{self.total} ({100 * self.done / self.total:.0f} %)  "
                  f"{rate:,.0f}/s  eta {eta:.0f} s", file=sys.stderr, flush=True)

    def __exit__(self, *exc) -> None:
        if self._bar is not None:
            self._bar.__exit__(*exc)
