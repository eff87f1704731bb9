"""Bounded polling waits: the only place tests wait for something to happen."""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import Any


def wait_for(condition: Callable[[], bool], *, timeout_s: float = 30.0, interval_s: float = 0.02,
             what: str = "condition") -> None:
    """Poll ``condition`` until it is true; fail after ``timeout_s``."""
    deadline = time.monotonic() + timeout_s
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out after {timeout_s} s waiting for {what}")
        time.sleep(interval_s)


def line_count(path: Path) -> int:
    """Complete lines in a file being written (0 while it does not exist yet), for ``wait_for``."""
    try:
        return path.read_text().count("\n")
    except FileNotFoundError:
        return 0


async def wait_for_app(pilot: Any, condition: Callable[[], bool], *, timeout_s: float = 30.0,
                       what: str = "condition") -> None:
    """Pump a Textual pilot (``await pilot.pause``) until ``condition`` holds; fail after ``timeout_s``."""
    deadline = time.monotonic() + timeout_s
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out after {timeout_s} s waiting for {what}")
        await pilot.pause(0.02)
