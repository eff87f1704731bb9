"""Two writers upserting the same runs in opposite orders at once (two rigs whose folders name the same
runs differently): on PostgreSQL each row insert locks its uid, so rows taken in opposite orders deadlock
and the server aborts one writer's batch, unless every writer takes the rows in one order."""

from __future__ import annotations

import threading
import uuid

from fleet.catalog.database import open_catalog
from fleet.catalog.entry import Entry
from fleet.catalog.runs import _row, _upsert, list_entries

ROWS = 3000


def test_opposite_orders_do_not_deadlock(postgres_url: str) -> None:
    from tests.fleet.conftest import _drop_tables

    _drop_tables(postgres_url)
    uids = [uuid.uuid4().hex for _ in range(ROWS)]
    rows = [_row(Entry(uid=u, path=f"/runs/{u}", machine="m", axis="X", kind="straightness",
                       created="2026-01-01T00:00:00Z", status="complete", content_hash="0" * 64)) for u in uids]
    errors: list[BaseException] = []
    with open_catalog(postgres_url) as cat:
        for _ in range(3):
            start = threading.Barrier(2)

            def write(batch: list[dict], start: threading.Barrier = start) -> None:
                start.wait()
                try:
                    _upsert(cat, batch)
                except Exception as exc:  # noqa: BLE001 - the deadlock, to be reported below
                    errors.append(exc)

            threads = [threading.Thread(target=write, args=(b,)) for b in (rows, rows[::-1])]
            for t in threads:
                t.start()
            for t in threads:
                t.join()
        assert not errors, [str(e).splitlines()[0] for e in errors]
        assert len(list_entries(cat)) == ROWS
    _drop_tables(postgres_url)
