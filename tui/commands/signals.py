"""Signals of the long-running commands (``probe --follow``, ``compensate live``)."""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Iterator


@contextlib.contextmanager
def ctrl_c_raises() -> Iterator[None]:
    """Ctrl-C (SIGINT) raises KeyboardInterrupt while the block runs, whatever the process inherited.

    A command that ends only on Ctrl-C (``probe --follow``, ``compensate live``, which then writes offset 0):
    a process started with SIGINT ignored (a background job of a non-interactive shell, and its children)
    keeps it ignored in Python, and would never end.
    """
    if threading.current_thread() is not threading.main_thread():  # only the main thread may set handlers
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
