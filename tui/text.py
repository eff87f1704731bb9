"""Text from a run (a machine, axis, operator or run name, a path) inside Textual markup, shown as it is."""

from __future__ import annotations

from saved_runs.errors import printable


def literal(text: object) -> str:
    """``text`` for a markup string: its control characters escaped (:func:`saved_runs.errors.printable`) and
    every ``[`` escaped, so that a machine named ``[bold red]X`` (or ``x [5m``, which Textual's own ``escape``
    lets through and which then breaks the markup after it) is shown literally.  A backslash at the end would
    escape the tag that follows: it gets a space after it."""
    s = printable(text).replace("[", "\\[")
    return s + " " if s.endswith("\\") else s
