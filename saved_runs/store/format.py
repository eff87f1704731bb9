"""The run format's names (docs/run-format.md): the format id and versions, the run kinds, the
points.csv columns of each kind, and how a value is written to points.csv (exactly round-trip)."""

from __future__ import annotations

import math
from datetime import UTC, datetime
from typing import Any

from processing.columns import (
    POSITIONING_LINEAR,
    POSITIONING_ROTARY,
    STRAIGHTNESS_POINTS_V2,
)

from ..errors import RunFormatError

FORMAT = "guideway-run"
VERSION = 2
SUPPORTED_VERSIONS = (1, 2)
KINDS = ("straightness", "positioning")


def point_columns(kind: str, axis_type: str | None = None) -> tuple[str, ...]:
    """The points.csv columns of a run kind (and axis type for positioning runs), current version.

    Reading an older version, a column it lacks takes its default (``OPTIONAL_DEFAULTS``).
    """
    if kind == "straightness":
        return STRAIGHTNESS_POINTS_V2
    if kind == "positioning":
        if axis_type == "rotary":
            return POSITIONING_ROTARY
        if axis_type in (None, "linear"):
            return POSITIONING_LINEAR
        raise RunFormatError(f"unknown axis_type {axis_type!r} (use linear or rotary)")
    raise RunFormatError(f"unknown run kind {kind!r}")


def format_cell(value: Any) -> str:
    """CSV text of one value: ints as ints, floats round-trip exactly (repr)."""
    if isinstance(value, bool):
        return str(int(value))
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return repr(value) if math.isfinite(value) else "nan"
    return str(value)


def run_axis(meta: dict[str, Any]) -> str:
    """The axis a run names: run.json ``axis``, else its positioning set-up's ``axis_name``; "" when neither."""
    return str(meta.get("axis") or (meta.get("setup") or {}).get("axis_name") or "")


def utc_now_iso() -> str:
    """Now, as run.json and the writer lock record times: ``2026-11-26T20:11:47Z`` (UTC, seconds)."""
    return datetime.now(UTC).isoformat(timespec="seconds").replace("+00:00", "Z")
