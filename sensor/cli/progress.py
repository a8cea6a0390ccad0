"""Progress on stderr for the commands and examples that run longer than about 2 s.

A rich spinner with the elapsed time (a bar when the work reports its steps), drawn only
when stderr is a terminal and ``--quiet`` is not given, and removed when the work ends, so
stdout and logs stay clean.
"""

from __future__ import annotations

import argparse
import contextlib
import sys
import time


def add_quiet_argument(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--quiet", action="store_true", help="no progress display on stderr")


def shown(quiet: bool = False) -> bool:
    """Whether progress is drawn: stderr is a terminal and not ``quiet``."""
    return not quiet and sys.stderr.isatty()


@contextlib.contextmanager
def busy(description: str, quiet: bool = False):
    """Show ``description`` with a spinner and the elapsed time while the block runs. Yields
    ``step(label)`` to change the text shown after the description (a no-op when quiet)."""
    if not shown(quiet):
        yield lambda label: None
        return
    from rich.console import Console
    from rich.progress import Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

    with Progress(SpinnerColumn(), TextColumn("{task.description}"), TimeElapsedColumn(),
                  TextColumn("{task.fields[label]}"), console=Console(stderr=True),
                  transient=True) as bar:
        task = bar.add_task(description, total=None, label="")
        yield lambda label: bar.update(task, label=label)


@contextlib.contextmanager
def counting(description: str, quiet: bool = False):
    """:func:`busy` for work that reports ``progress(done, total, label)`` (the pneumatic studies)."""
    with busy(description, quiet) as step:
        yield lambda done, total, label: step(f"{done}/{total} {label}")


class CountingBar:
    """A rich bar of items done, their rate and the time left, for work that reports its
    items through ``start(total)``, ``advance(n)`` and ``stop()`` (e.g. ``run_sweep``)."""

    def __init__(self, description: str, unit: str):
        from rich.console import Console
        from rich.progress import (
            BarColumn,
            MofNCompleteColumn,
            Progress,
            TextColumn,
            TimeRemainingColumn,
        )

        self.unit = unit
        self.bar = Progress(TextColumn(description), BarColumn(), MofNCompleteColumn(),
                            TextColumn("{task.fields[rate]}"), TimeRemainingColumn(),
                            console=Console(stderr=True), transient=True)

    def start(self, total: int) -> None:
        self.t0 = time.monotonic()
        self.task = self.bar.add_task(self.unit, total=total, rate="")
        self.bar.start()

    def advance(self, n: int) -> None:
        done = self.bar.tasks[0].completed + n
        rate = done / max(time.monotonic() - self.t0, 1e-9)
        self.bar.update(self.task, advance=n, rate=f"{rate:.0f} {self.unit}/s")

    def stop(self) -> None:
        self.bar.stop()
