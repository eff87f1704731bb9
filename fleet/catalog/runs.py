"""Adding, listing and removing the catalogue's runs (``guideway catalog``), on SQLite or PostgreSQL alike.

Adding is idempotent and safe with several processes at once: a run is keyed by its uid and written with
one ``INSERT ... ON CONFLICT (uid) DO UPDATE`` (both databases have it), so two rigs adding the same runs
leave one entry each and lose none; each says what it wrote itself (``RETURNING``), not what the other wrote.
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import sqlalchemy as sa

from saved_runs.errors import UserError
from saved_runs.store.files import read_run_file

from .database import Catalog, runs_table
from .entry import Entry, RunFiles, RunUnreadable, identity, make_entry, read_run_files

BATCH = 200  # rows written per transaction while scanning


@dataclass(frozen=True)
class AddOutcome:
    """What adding one run directory did: ``added``, ``unchanged``, ``updated`` (edited since it was added),
    ``moved`` (same run found in a new place), ``copy`` (a second directory of an entry whose own directory
    still exists: left as it is) or ``unreadable``; ``message`` says it in one line."""

    path: str
    action: str
    message: str
    uid: str = ""


def scan_run_dirs(folder: Path | str) -> list[Path]:
    """Every directory under ``folder`` (at any depth, ``folder`` itself included) holding a run.json, and
    every directory that could not be listed (so that adding it reports it as unreadable); the results/
    folders of runs are not entered."""
    folder = Path(folder)
    if not folder.is_dir():
        raise UserError(f"--scan {folder}: not a folder; give the folder that holds the run directories")
    found = []
    for here, dirs, files in os.walk(folder, onerror=lambda exc: found.append(Path(exc.filename))):
        if "run.json" in files:
            found.append(Path(here))
            dirs[:] = []  # a run directory holds no runs
        else:
            dirs.sort()
    return sorted(found)


def _now() -> str:
    return datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%SZ")


def _row(entry: Entry) -> dict[str, Any]:
    options = json.dumps({"options": entry.options or {}, "defaults": entry.option_defaults}, allow_nan=False)
    return {"uid": entry.uid, "path": entry.path, "machine": entry.machine, "axis": entry.axis, "kind": entry.kind,
            "created": entry.created, "status": entry.status, "values_json": json.dumps(entry.values, allow_nan=False),
            "verdict": entry.verdict, "content_hash": entry.content_hash, "added": _now(), "options_json": options,
            "facts_json": None if entry.facts is None else json.dumps(entry.facts, allow_nan=False)}



def _upsert(cat: Catalog, rows: list[dict[str, Any]]) -> tuple[set[str], set[str]]:
    """Insert ``rows``, or replace the entries of their uids that hold other content (one statement: no duplicate,
    no lost entry when another process writes the same uids at the same time); return the uids this call
    inserted and those it replaced.  A uid in neither was written, with the same content, by another process
    between our look and our write (two rigs adding the same run at once: only one of them added it)."""
    if not rows:
        return set(), set()
    t = runs_table
    if cat.dialect == "postgresql":
        from sqlalchemy.dialects.postgresql import insert
    else:
        from sqlalchemy.dialects.sqlite import insert
    stmt = insert(t)
    keep = {c: stmt.excluded[c] for c in _row_columns() if c not in ("uid", "added")}
    other_content = sa.or_(t.c.content_hash != stmt.excluded.content_hash, t.c.options_json.is_(None))
    # in uid order: each row locks its uid until the commit (PostgreSQL), so two writers taking the same uids
    # in different orders (two rigs whose folders name the runs differently) would deadlock
    rows = sorted(rows, key=lambda r: r["uid"])
    with cat.engine.begin() as conn:
        if cat.dialect == "postgresql":
            # one statement; xmax = 0 in the row returned: inserted by it (else: an existing row it updated)
            upsert = stmt.on_conflict_do_update(index_elements=["uid"], set_=keep, where=other_content).returning(
                t.c.uid, sa.literal_column("(xmax = 0)").label("inserted"))
            done = conn.execute(upsert, rows).all()
            return {r.uid for r in done if r.inserted}, {r.uid for r in done if not r.inserted}
        # SQLite: the first statement takes the database's write lock until the commit, so nothing comes between
        inserted = set(conn.execute(stmt.on_conflict_do_nothing(index_elements=["uid"]).returning(t.c.uid),
                                    rows).scalars())
        rest = [r for r in rows if r["uid"] not in inserted]
        updated = set(conn.execute(stmt.on_conflict_do_update(index_elements=["uid"], set_=keep, where=other_content)
                                   .returning(t.c.uid), rest).scalars()) if rest else set()
        return inserted, updated


def _row_columns() -> list[str]:
    return [c.name for c in runs_table.columns]


def _set_path(cat: Catalog, moves: list[tuple[str, str]]) -> None:
    if not moves:
        return
    with cat.engine.begin() as conn:
        conn.execute(sa.update(runs_table).where(runs_table.c.uid == sa.bindparam("u")).values(path=sa.bindparam("p")),
                     [{"u": uid, "p": path} for uid, path in moves])


def _known(cat: Catalog, uids: Iterable[str]) -> dict[str, tuple[str, str, bool]]:
    """uid -> (content hash, path, whether the entry records its evaluation options) of the entries among
    ``uids`` (an entry of schema 1 does not: it is written again)."""
    uids = list(uids)
    out: dict[str, tuple[str, str, bool]] = {}
    t = runs_table
    with cat.engine.connect() as conn:
        for i in range(0, len(uids), 500):
            q = sa.select(t.c.uid, t.c.content_hash, t.c.path, t.c.options_json.is_not(None).label("current")).where(
                t.c.uid.in_(uids[i:i + 500]))
            out.update({r.uid: (r.content_hash, r.path, bool(r.current)) for r in conn.execute(q)})
    return out


def still_holds(path: str, uid: str) -> bool:
    """Whether ``path`` still holds the run ``uid`` (else the run has moved away from it)."""
    try:
        return json.loads(read_run_file(Path(path) / "run.json")).get("uid") == uid
    except (OSError, ValueError, AttributeError, UserError):  # UserError: not a regular file (a FIFO)
        return False


def _check_lengths(f: RunFiles) -> None:
    """Refuse a run whose uid, machine, axis, ... is longer than its column or holds a NUL character:
    PostgreSQL would refuse the whole batch of rows with it ("value too long", "cannot contain NUL"), SQLite
    would keep it; refused here, on both alike."""
    for name, text in {"uid": f.uid, **identity(f.meta)}.items():
        if "\0" in text:
            raise RunUnreadable(f"{f.path}: run.json {name} holds a NUL character (\\u0000), which the catalogue "
                                "cannot store: remove it from run.json and add the run again")
        limit = runs_table.c[name].type.length
        if len(text) > limit:
            raise RunUnreadable(f"{f.path}: run.json {name} is {len(text)} characters long; the catalogue holds "
                                f"at most {limit}: shorten it in run.json and add the run again")


def add_runs(cat: Catalog, run_dirs: Iterable[Path | str], *,
             progress: Callable[[int, int], None] | None = None) -> Iterator[AddOutcome]:
    """Add each run directory to the catalogue, yielding what happened to each (the unreadable ones first,
    then the others): an unreadable directory is reported and the others are added.  An ``added``,
    ``updated`` or ``moved`` outcome is yielded once its row is written, so that a database failing half
    way has not been told as having added what it has not.  ``progress(done, total)``: the readable runs
    looked at (each new or edited one evaluated), for a front end's progress display."""
    read: list[RunFiles] = []
    for d in run_dirs:
        try:
            files = read_run_files(d)
            _check_lengths(files)
            read.append(files)
        except RunUnreadable as exc:
            yield AddOutcome(str(d), "unreadable", f"unreadable: {exc}")
    known = _known(cat, {f.uid for f in read})
    pending: list[dict[str, Any]] = []
    told: list[AddOutcome] = []  # the outcomes of ``pending``, yielded once written
    moves: list[tuple[str, str]] = []
    moved: list[AddOutcome] = []
    seen: dict[str, str] = {}
    for done, f in enumerate(read):
        if progress is not None:
            progress(done, len(read))
        path = str(f.path)
        if f.uid in seen:
            yield AddOutcome(path, "copy", f"copy: {path} holds run {f.uid}, as {seen[f.uid]} does; left out", f.uid)
            continue
        seen[f.uid] = path
        old = known.get(f.uid)
        if old is not None and old[0] == f.content_hash and old[2]:
            if old[1] == path:
                yield AddOutcome(path, "unchanged", f"unchanged: {path}", f.uid)
            elif still_holds(old[1], f.uid):
                yield AddOutcome(path, "copy", f"copy: {path} holds run {f.uid}, catalogued at {old[1]} which still "
                                 "holds it; left as it is", f.uid)
            else:
                moves.append((f.uid, path))
                moved.append(AddOutcome(path, "moved", f"moved: run {f.uid} found again at {path} (was {old[1]})",
                                        f.uid))
            continue
        entry = make_entry(f)
        pending.append(_row(entry))
        note = f" ({entry.note})" if entry.note else ""
        if old is None:
            told.append(AddOutcome(path, "added", f"added: {path}{note}", f.uid))
        elif old[0] == f.content_hash:  # an entry of schema 1: without the evaluation options (and maybe verdict)
            told.append(AddOutcome(path, "updated", f"updated: {path}: its entry, written by an older guideway, now "
                                   f"holds the evaluation options and the verdict{note}", f.uid))
        else:
            told.append(AddOutcome(path, "updated", f"updated: {path} was edited since it was added (run.json or "
                                   f"points.csv changed); its entry now holds the run as it is{note}", f.uid))
        if len(pending) >= BATCH:
            yield from _written(cat, pending, told)
            pending, told = [], []
    if progress is not None:
        progress(len(read), len(read))
    yield from _written(cat, pending, told)
    _set_path(cat, moves)
    yield from moved


def _written(cat: Catalog, rows: list[dict[str, Any]], told: list[AddOutcome]) -> Iterator[AddOutcome]:
    """Write ``rows`` and yield their outcomes as this process wrote them: a run another process catalogued
    between our look and our write is told as it now is (unchanged, or a copy of the other's), not as added."""
    inserted, updated = _upsert(cat, rows)
    others = [o for o in told if o.uid not in inserted and o.uid not in updated]
    now = _known(cat, [o.uid for o in others]) if others else {}
    for o in told:
        if o.uid in inserted:
            yield o if o.action == "added" else AddOutcome(o.path, "added", f"added: {o.path}", o.uid)
        elif o.uid in updated:
            yield o if o.action == "updated" else AddOutcome(
                o.path, "updated", f"updated: {o.path}: catalogued at the same time by another process, with "
                "other content; its entry now holds the run as it is here", o.uid)
        else:
            where = now.get(o.uid, ("", o.path, True))[1]
            if where == o.path:
                yield AddOutcome(o.path, "unchanged", f"unchanged: {o.path} (catalogued at the same time by another "
                                 "process)", o.uid)
            else:
                yield AddOutcome(o.path, "copy", f"copy: {o.path} holds run {o.uid}, catalogued at the same time by "
                                 f"another process at {where}; left as it is", o.uid)


def entry_of_row(row: Any) -> Entry:
    options = json.loads(row.options_json) if row.options_json else {}  # none in the rows of schema 1
    facts = getattr(row, "facts_json", None)  # none in the rows of schema 1 and 2
    return Entry(uid=row.uid, path=row.path, machine=row.machine, axis=row.axis, kind=row.kind, created=row.created,
                 status=row.status, content_hash=row.content_hash, values=json.loads(row.values_json),
                 verdict=row.verdict, options=options.get("options"), option_defaults=options.get("defaults") or {},
                 facts=json.loads(facts) if facts else None)


def since_text(date: str) -> str:
    """``--since DATE`` (``YYYY-MM-DD`` or an ISO 8601 time, UTC) as the catalogue's ``created`` text."""
    try:
        when = datetime.fromisoformat(date.replace("Z", "+00:00"))
    except ValueError:
        raise UserError(f"--since {date!r} is not a date; give YYYY-MM-DD or YYYY-MM-DDTHH:MM:SSZ (UTC)") from None
    if when.tzinfo is not None:
        when = when.astimezone(UTC)
    return when.strftime("%Y-%m-%dT%H:%M:%SZ")


def list_entries(cat: Catalog, *, machine: str | None = None, axis: str | None = None, kind: str | None = None,
                 since: str | None = None, oldest_first: bool = False) -> list[Entry]:
    """The catalogue's entries that match every filter given (``since``: ``created`` at or after it),
    newest first (or oldest first)."""
    t = runs_table
    q = sa.select(t)
    for column, value in ((t.c.machine, machine), (t.c.axis, axis), (t.c.kind, kind)):
        if value is not None:
            q = q.where(column == value)
    if since is not None:
        q = q.where(t.c.created >= since_text(since))
    q = q.order_by(t.c.created.asc() if oldest_first else t.c.created.desc(), t.c.uid)
    with cat.engine.connect() as conn:
        return [entry_of_row(r) for r in conn.execute(q)]


def remove_run(cat: Catalog, run: str) -> Entry:
    """Remove the entry of ``run`` (a run directory, its uid, or the path the catalogue holds for it)."""
    t = runs_table
    uid = run
    if (Path(run) / "run.json").is_file():
        uid = read_run_files(run).uid
    with cat.engine.begin() as conn:
        row = conn.execute(sa.select(t).where(t.c.uid == uid)).first()
        if row is None:
            row = conn.execute(sa.select(t).where(t.c.path == str(Path(run).resolve()))).first()
        if row is None:
            raise UserError(f"{run}: no such run in the catalogue {cat.url}; see guideway catalog list")
        conn.execute(sa.delete(t).where(t.c.uid == row.uid))
    return entry_of_row(row)


def write_entries(cat: Catalog, entries: Iterable[Entry]) -> int:
    """Write ``entries`` as they are (no run directory read), ``BATCH`` rows per transaction; return how many
    rows were inserted or replaced.  For tools and tests that build a catalogue from entries."""
    rows = [_row(e) for e in entries]
    done = 0
    for i in range(0, len(rows), BATCH * 5):
        inserted, updated = _upsert(cat, rows[i:i + BATCH * 5])
        done += len(inserted) + len(updated)
    return done
