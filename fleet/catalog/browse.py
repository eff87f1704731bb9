"""What the runs browser needs of the catalogue: its runs filtered by machine and axis (as the browser's
:class:`~saved_runs.catalog.folder.RunSummary` rows, with the uid kept), the machines and axes to filter
by, and the value a run's trend shows first."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from saved_runs.catalog.folder import RunSummary

from .database import open_catalog
from .entry import Entry
from .runs import list_entries

DEFAULT_TREND_VALUE = {"straightness": "minimum_zone", "positioning": "E"}


@dataclass(frozen=True)
class CatalogFilter:
    """The browser's filter: None for "any"."""

    machine: str | None = None
    axis: str | None = None


@dataclass(frozen=True)
class CatalogView:
    """The filtered runs (newest first), their entries (same order), and every machine and axis of the
    catalogue (each sorted) to offer as filters; ``url`` as it may be shown."""

    url: str
    runs: list[RunSummary]
    entries: list[Entry]
    machines: list[str] = field(default_factory=list)
    axes: list[str] = field(default_factory=list)


def summary_of(entry: Entry) -> RunSummary:
    return RunSummary(Path(entry.path), kind=entry.kind, created=entry.created, machine=entry.machine,
                      axis=entry.axis, status=entry.status)


def browse_catalog(url: str | None, flt: CatalogFilter = CatalogFilter()) -> CatalogView:
    """The catalogue's runs matching ``flt`` (raises the catalogue's one-line UserError when it cannot be
    opened)."""
    import sqlalchemy as sa

    from .database import runs_table as t

    with open_catalog(url, create=False) as cat:
        entries = list_entries(cat, machine=flt.machine, axis=flt.axis)
        with cat.engine.connect() as conn:
            machines = conn.execute(sa.select(t.c.machine).distinct().order_by(t.c.machine)).scalars().all()
            q = sa.select(t.c.axis).distinct().order_by(t.c.axis)
            if flt.machine is not None:
                q = q.where(t.c.machine == flt.machine)
            axes = conn.execute(q).scalars().all()
        return CatalogView(cat.url, [summary_of(e) for e in entries], entries, list(machines), list(axes))


def trend_values(entries: list[Entry], machine: str, axis: str) -> list[str]:
    """The values the runs of ``machine`` / ``axis`` have, in the order a trend offers them."""
    names: list[str] = []
    for e in entries:
        if e.machine == machine and e.axis == axis:
            names += [n for n in e.values if n not in names]
    first = [v for v in DEFAULT_TREND_VALUE.values() if v in names]
    return first + [n for n in names if n not in first]
