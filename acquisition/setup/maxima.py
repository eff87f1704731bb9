"""The documented maxima of a run's sizes (docs/acquisition.md, "Sizes"), in one place.

The set-up loaders, ``guideway demo``'s options and the TUI's set-up form check a size against
these before anything is allocated: a station count of 10^12 is one line and exit 2, never a list
of 10^12 steps.  Each maximum is far above any real machine and low enough that a run of that size
fits in memory (a 100,000-station straightness run is benchmarked end to end).  Pure Python, no
imports but the error class: ``guideway --help`` reads the option limits from here.
"""

from __future__ import annotations

import math

from saved_runs.errors import SetupError

STATIONS_MAX = 100_000  # straightness stations per pass, the datum included
BLOCK_LENGTH_MAX_MM = 10_000.0  # gauge-block length = step between stations (10 m)
TRAVEL_MAX_MM = 100_000.0  # a linear positioning axis's travel, and a straightness travel_length_mm (100 m)
SAMPLES_PER_READING_MAX = 10_000  # sensor samples averaged per capture (5 s of an ILD1420 at 2 kHz)
TARGETS_MAX = 1_000  # positioning targets (given, generated, or rotary targets_per_rev)
RUNS_MAX = 100  # positioning approaches per direction (ISO 230-2 asks for 5)
WARMUP_WINDOW_MAX = 10_000  # readings in the warm-up drift window

DOC = "docs/acquisition.md, Sizes"

SPLIT = "; measure a longer axis in several runs"
# the largest value of each size, its unit and what to do instead, by the key the messages use
MAXIMA: dict[str, tuple[float, str, str]] = {
    "stations": (STATIONS_MAX, "stations", SPLIT),
    "length_mm": (BLOCK_LENGTH_MAX_MM, "mm", ""),
    "travel_length_mm": (TRAVEL_MAX_MM, "mm", SPLIT),
    "travel_mm": (TRAVEL_MAX_MM, "mm", SPLIT),
    "samples_per_reading": (SAMPLES_PER_READING_MAX, "samples", ""),
    "targets": (TARGETS_MAX, "targets", SPLIT),
    "targets_per_rev": (TARGETS_MAX, "targets", ""),
    "runs": (RUNS_MAX, "runs", ""),
    "window": (WARMUP_WINDOW_MAX, "readings", ""),
}


def size_problem(name: str, value: float) -> str | None:
    """Why ``value`` of the size ``name`` (a key of :data:`MAXIMA`) is beyond its maximum (one line
    without the set-up's name), or None.  A NaN or infinite value is beyond every maximum."""
    limit, unit, instead = MAXIMA[name]
    if isinstance(value, int | float) and math.isfinite(value) and value <= limit:
        return None
    shown = f"{value:g}" if isinstance(value, float) else str(value)
    return f"{name} = {shown} is beyond the maximum of {limit:g} {unit} ({DOC}){instead}"


def check_size(name: str, value: float, where: str = "") -> None:
    """Raise a one-line :class:`~saved_runs.errors.SetupError` (``where`` first, e.g. ``[block]``) when
    ``value`` is beyond the maximum of ``name``."""
    if (problem := size_problem(name, value)) is not None:
        raise SetupError(f"{where} {problem}" if where else problem)
