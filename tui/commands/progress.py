"""The progress of long command-line work (``process`` of a big run, ``catalog add --scan``, ``diagnose``,
``volumetric``) on a terminal.

The work itself lives below the front end (saved_runs/, fleet/) and reports through a callback
``progress(done, total)``; this module draws it with rich.progress on stderr, and only when stderr is a
terminal and the command prints no JSON: piped, redirected or ``--json``, the command writes exactly
what it wrote without the display (the callbacks are None, the work calls nothing).  The display is
transient: it is erased when the work ends (or fails, before the one-line error), so a terminal keeps
the command's own output only.  rich is imported only when a display is drawn: ``guideway --help`` and
every piped command load none of it.
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

Progress = Callable[[int, int], None]


class Stages:
    """The stages of one command's work, drawn as one line: a description, a bar once the total is known,
    done/total and the elapsed time.  Without a terminal, every stage is None (nothing drawn)."""

    def stage(self, description: str, total: int | None = None) -> Progress | None:
        """Start the stage ``description`` (``total`` steps if known); the callback its work reports to."""
        return None


class _Drawn(Stages):
    def __init__(self, progress: Any) -> None:
        self._progress = progress
        self._task: Any = None

    def stage(self, description: str, total: int | None = None) -> Progress:
        # a task per stage (rich keeps a task's total once set): its own bar and its own elapsed time
        if self._task is not None:
            self._progress.refresh()  # the stage's last count is drawn, however soon the next one starts
            self._progress.remove_task(self._task)
        task = self._task = self._progress.add_task(description, total=total)

        def report(done: int, total: int) -> None:
            self._progress.update(task, completed=done, total=total)

        return report


def short(path: Path | str) -> str:
    """A path as a stage names it: its last part (a long path would push the counts off an 80-column line)."""
    return Path(path).resolve().name or str(path)


def wanted(*, json_output: bool = False) -> bool:
    """Whether to draw: stderr is a terminal and no JSON is printed."""
    if json_output:
        return False
    try:
        return sys.stderr.isatty()
    except (AttributeError, ValueError):  # a closed or replaced stream
        return False


@contextmanager
def progress_display(*, json_output: bool = False) -> Iterator[Stages]:
    """The stages of a command's work, drawn on stderr while the block runs (see the module's doc)."""
    if not wanted(json_output=json_output):
        yield Stages()
        return
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, SpinnerColumn, TextColumn, TimeElapsedColumn
    from rich.progress import Progress as RichProgress

    console = Console(file=sys.stderr)
    # Lines printed meanwhile go above the display: stderr's always (warnings), stdout's only when it is a
    # terminal too (catalog add's lines); a piped stdout is left alone, byte for byte.
    with RichProgress(SpinnerColumn(), TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
                      TimeElapsedColumn(), console=console, transient=True,
                      redirect_stdout=sys.stdout.isatty(), redirect_stderr=True) as progress:
        yield _Drawn(progress)
