"""Fixtures of the catalogue tests: every test taking ``catalog_url`` runs on SQLite and on a real
PostgreSQL server started for the session (postgres_server.py)."""

from __future__ import annotations

import subprocess
from collections.abc import Iterator
from pathlib import Path

import pytest

from .postgres_server import postgres_server, required


@pytest.fixture(scope="session")
def postgres_url() -> Iterator[str]:
    """The URL of the session's PostgreSQL server (skipped without the binaries, except in CI)."""
    try:
        with postgres_server() as url:
            yield url
    except FileNotFoundError as exc:
        if required():
            pytest.fail(f"{exc} (CI must run the PostgreSQL tests)", pytrace=False)
        pytest.skip(f"{exc}; the PostgreSQL tests need the server locally")
    except subprocess.CalledProcessError as exc:
        pytest.fail(f"the test PostgreSQL server did not start: {exc.stderr!r}", pytrace=False)


def _drop_tables(url: str) -> None:
    import sqlalchemy as sa

    engine = sa.create_engine(url.replace("postgresql://", "postgresql+psycopg://"))
    with engine.begin() as conn:
        conn.execute(sa.text("DROP TABLE IF EXISTS guideway_runs, guideway_catalog, guideway_tolerances, "
                             "guideway_intervals"))
    engine.dispose()


@pytest.fixture(params=["sqlite", "postgresql"])
def catalog_url(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[str]:
    """An empty catalogue: a new SQLite file, or the session's PostgreSQL server without the tables."""
    if request.param == "sqlite":
        yield f"sqlite:///{tmp_path / 'catalog.sqlite'}"
        return
    url = request.getfixturevalue("postgres_url")
    _drop_tables(url)
    yield url
    _drop_tables(url)
