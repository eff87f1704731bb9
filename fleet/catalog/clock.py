"""Runs dated in the future: a run whose run.json ``created`` is later than now + ``FUTURE_MARGIN`` (a rig
whose clock says 2099) is flagged by ``catalog list`` and left out of trends, where its far date would
flatten the line (docs/fleet.md)."""

from __future__ import annotations

from datetime import UTC, datetime, timedelta

# A day of grace: a rig clock a few hours fast, or a local time written without its offset and read as UTC
# (up to 14 h ahead), is not a run from the future.
FUTURE_MARGIN = timedelta(days=1)


def future_cutoff(now: datetime | None = None) -> datetime:
    """The latest ``created`` that is not in the future: ``now`` (default: the system clock, UTC) + 1 day."""
    return (now or datetime.now(UTC)) + FUTURE_MARGIN


def is_future(created: str, now: datetime | None = None) -> bool:
    """Whether ``created`` (ISO 8601, UTC when it names no zone) is later than now + ``FUTURE_MARGIN``;
    False for text that is not a time."""
    try:
        when = datetime.fromisoformat(created.strip().replace("Z", "+00:00"))
    except ValueError:
        return False
    if when.tzinfo is None:
        when = when.replace(tzinfo=UTC)
    return when > future_cutoff(now)
