"""What the catalogue keeps per machine axis besides its runs (schema 3): the tolerance of a headline value
(``guideway catalog tolerance``) and the calibration interval (``guideway catalog interval``), for the fleet
overview (docs/fleet.md, "Fleet overview").  Written with one upsert each, on SQLite and PostgreSQL alike."""

from __future__ import annotations

import math
from dataclasses import dataclass
from datetime import UTC, datetime
from typing import Any

import sqlalchemy as sa

from saved_runs.errors import UserError

from .database import Catalog, intervals_table, tolerances_table

# The headline values a tolerance may be set on (entry.py): straightness against each reference line, and the
# ISO 230-2 values of a positioning run (B_mean: its limit bounds |B_mean|).
TOLERANCE_VALUES = ("minimum_zone", "least_squares", "endpoint", "A", "A_up", "A_down", "E", "E_up", "E_down",
                    "M", "R", "R_up", "R_down", "B", "B_mean")


@dataclass(frozen=True)
class Tolerance:
    """The limit of ``value`` on ``machine`` / ``axis`` (µm, arc-seconds on a rotary axis)."""

    machine: str
    axis: str
    value: str
    limit_um: float
    set_at: str = ""

    def to_dict(self) -> dict[str, Any]:
        return {"machine": self.machine, "axis": self.axis, "value": self.value, "limit_um": self.limit_um,
                "set_at": self.set_at}


@dataclass(frozen=True)
class Interval:
    """The calibration interval of ``machine`` / ``axis``: a run is due ``days`` after the last one."""

    machine: str
    axis: str
    days: float
    set_at: str = ""

    def to_dict(self) -> dict[str, Any]:
        return {"machine": self.machine, "axis": self.axis, "days": self.days, "set_at": self.set_at}


def _now() -> str:
    return datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%SZ")


def _check_names(machine: str, axis: str) -> None:
    for what, text in (("--machine", machine), ("--axis", axis)):
        if "\0" in text or len(text) > 255:
            raise UserError(f"{what} {text[:40]!r}...: at most 255 characters and no NUL character")


def _upsert(cat: Catalog, table: sa.Table, row: dict[str, Any], keys: list[str]) -> None:
    if cat.dialect == "postgresql":
        from sqlalchemy.dialects.postgresql import insert
    else:
        from sqlalchemy.dialects.sqlite import insert
    stmt = insert(table).values(**row)
    stmt = stmt.on_conflict_do_update(index_elements=keys, set_={k: stmt.excluded[k] for k in row if k not in keys})
    with cat.engine.begin() as conn:
        conn.execute(stmt)


def set_tolerance(cat: Catalog, machine: str, axis: str, value: str, limit_um: float) -> Tolerance:
    """Keep ``limit_um`` as the tolerance of ``value`` on ``machine`` / ``axis`` (replacing one set before)."""
    _check_names(machine, axis)
    if value not in TOLERANCE_VALUES:
        raise UserError(f"--value {value!r} is not a headline value; give one of {', '.join(TOLERANCE_VALUES)}")
    if not (math.isfinite(limit_um) and limit_um > 0):
        raise UserError(f"--limit must be a positive number (um, arcsec on a rotary axis), got {limit_um}")
    tol = Tolerance(machine, axis, value, float(limit_um), _now())
    _upsert(cat, tolerances_table, {"machine": machine, "axis": axis, "value": value, "limit_um": tol.limit_um,
                                    "set_at": tol.set_at}, ["machine", "axis", "value"])
    return tol


def set_interval(cat: Catalog, machine: str, axis: str, days: float) -> Interval:
    """Keep ``days`` as the calibration interval of ``machine`` / ``axis`` (replacing one set before)."""
    _check_names(machine, axis)
    if not (math.isfinite(days) and days > 0):
        raise UserError(f"--days must be a positive number of days, got {days}")
    iv = Interval(machine, axis, float(days), _now())
    _upsert(cat, intervals_table, {"machine": machine, "axis": axis, "days": iv.days, "set_at": iv.set_at},
            ["machine", "axis"])
    return iv


def list_tolerances(cat: Catalog, machine: str | None = None) -> list[Tolerance]:
    t = tolerances_table
    q = sa.select(t).order_by(t.c.machine, t.c.axis, t.c.value)
    if machine is not None:
        q = q.where(t.c.machine == machine)
    with cat.engine.connect() as conn:
        return [Tolerance(r.machine, r.axis, r.value, float(r.limit_um), r.set_at) for r in conn.execute(q)]


def list_intervals(cat: Catalog, machine: str | None = None) -> list[Interval]:
    t = intervals_table
    q = sa.select(t).order_by(t.c.machine, t.c.axis)
    if machine is not None:
        q = q.where(t.c.machine == machine)
    with cat.engine.connect() as conn:
        return [Interval(r.machine, r.axis, float(r.days), r.set_at) for r in conn.execute(q)]


def remove_tolerance(cat: Catalog, machine: str, axis: str, value: str) -> None:
    """Forget the tolerance of ``value`` on ``machine`` / ``axis`` (the runs' own [tolerance] applies again)."""
    t = tolerances_table
    with cat.engine.begin() as conn:
        gone = conn.execute(sa.delete(t).where(t.c.machine == machine, t.c.axis == axis, t.c.value == value))
    if not gone.rowcount:
        raise UserError(f"no tolerance of {value!r} on machine {machine!r} axis {axis!r} in {cat.url}; see guideway "
                        "catalog tolerance --list")


def remove_interval(cat: Catalog, machine: str, axis: str) -> None:
    t = intervals_table
    with cat.engine.begin() as conn:
        gone = conn.execute(sa.delete(t).where(t.c.machine == machine, t.c.axis == axis))
    if not gone.rowcount:
        raise UserError(f"no calibration interval of machine {machine!r} axis {axis!r} in {cat.url}; see guideway "
                        "catalog interval --list")
