"""The catalogue's database: which one (``--catalog URL``, ``GUIDEWAY_CATALOG``, or a SQLite file in the
user's data directory), its one schema for SQLite and PostgreSQL (SQLAlchemy Core) with a version, and
opening it with one-line errors (an unreachable server, a missing driver, a newer schema).

SQLAlchemy is imported here and only here, lazily by the commands that open a catalogue, so
``guideway --help`` does not load it.  docs/fleet.md describes the schema.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import sqlalchemy as sa

from saved_runs.errors import UserError

from .config import configured_url

SCHEMA_VERSION = 1  # raise it with every change of the tables below (and say in docs/fleet.md what changed)
CONNECT_TIMEOUT_S = 10  # a PostgreSQL server that does not answer: give up after this long

metadata = sa.MetaData()

# One row per key: ``schema_version`` (the version of the tables, an integer as text).
info_table = sa.Table(
    "guideway_catalog", metadata,
    sa.Column("key", sa.String(64), primary_key=True),
    sa.Column("value", sa.String(255), nullable=False),
)

# One row per run, keyed by the run's uid (run.json ``uid``); ``created`` is run.json's ISO 8601 UTC text,
# which sorts as time does; ``values_json`` the headline values (entry.py), ``content_hash`` the SHA-256 of
# run.json and points.csv (entry.py).
runs_table = sa.Table(
    "guideway_runs", metadata,
    sa.Column("uid", sa.String(128), primary_key=True),
    sa.Column("path", sa.Text, nullable=False),
    sa.Column("machine", sa.String(255), nullable=False),
    sa.Column("axis", sa.String(255), nullable=False),
    sa.Column("kind", sa.String(32), nullable=False),
    sa.Column("created", sa.String(40), nullable=False),
    sa.Column("status", sa.String(32), nullable=False),
    sa.Column("values_json", sa.Text, nullable=False),
    sa.Column("verdict", sa.String(32), nullable=True),
    sa.Column("content_hash", sa.String(64), nullable=False),
    sa.Column("added", sa.String(40), nullable=False),
    sa.Index("ix_guideway_runs_machine_axis_created", "machine", "axis", "created"),
    sa.Index("ix_guideway_runs_created", "created"),
)


def default_url() -> str:
    """The SQLite file of one user on one rig: ``catalog.sqlite`` in the user's data directory
    (platformdirs: e.g. ``~/.local/share/guideway`` on Linux)."""
    import platformdirs

    return f"sqlite:///{Path(platformdirs.user_data_dir('guideway', appauthor=False)) / 'catalog.sqlite'}"


def catalog_url(given: str | None = None) -> str:
    """``given``, else ``GUIDEWAY_CATALOG``, else the default SQLite file."""
    return configured_url(given) or default_url()


def _parsed(url: str) -> Any:
    """The SQLAlchemy URL of ``url``; ``postgresql://`` and ``postgres://`` mean the psycopg 3 driver."""
    try:
        u = sa.engine.make_url(url)
    except sa.exc.ArgumentError:
        raise UserError(f"catalogue URL {url!r} is not a database URL; use sqlite:///PATH or "
                        "postgresql://USER@HOST/DATABASE (docs/fleet.md)") from None
    backend = u.get_backend_name()
    if backend == "postgres" or (backend == "postgresql" and u.drivername == "postgresql"):
        u = u.set(drivername="postgresql+psycopg")
    elif backend not in ("sqlite", "postgresql"):
        raise UserError(f"catalogue URL {shown(u)}: {backend} databases are not supported; use sqlite:///PATH or "
                        "postgresql://USER@HOST/DATABASE (docs/fleet.md)")
    return u


def shown(u: Any) -> str:
    """A URL as it may be printed: without its password."""
    return u.render_as_string(hide_password=True) if hasattr(u, "render_as_string") else str(u)


def _where(u: Any) -> str:
    """What an error names: the file of a SQLite catalogue, host and port of a server."""
    if u.get_backend_name() == "sqlite":
        return f"the SQLite file {u.database}"
    return f"the PostgreSQL server {u.host or 'localhost'}:{u.port or 5432} (database {u.database or '?'})"


@dataclass
class Catalog:
    """An open catalogue: its SQLAlchemy engine, the URL as shown to people, and whether it is SQLite."""

    engine: Any
    url: str
    where: str = ""

    @property
    def dialect(self) -> str:
        return str(self.engine.dialect.name)

    def close(self) -> None:
        self.engine.dispose()

    def __enter__(self) -> Catalog:
        return self

    def __exit__(self, kind: type[BaseException] | None, exc: BaseException | None, tb: object) -> None:
        self.close()
        if isinstance(exc, sa.exc.DBAPIError):  # the server went away or refused a statement half way
            raise UserError(f"the catalogue at {self.where or self.url} failed: {_first_line(exc)}; check the "
                            "server and run the command again (what was written before stays)") from None


def _engine(u: Any) -> Any:
    if u.get_backend_name() == "sqlite":
        if u.database and u.database != ":memory:":
            path = Path(u.database).expanduser()
            try:
                path.parent.mkdir(parents=True, exist_ok=True)
            except OSError as exc:
                raise UserError(f"cannot create the folder of the catalogue file {path} ({exc.strerror}); "
                                "check the path or give another with --catalog sqlite:///PATH") from None
        # several processes may add at once: wait for the file lock rather than fail at once
        return sa.create_engine(u, connect_args={"timeout": 60})
    try:
        if u.drivername == "postgresql+psycopg":
            import psycopg  # noqa: F401 - checked here so the message says what to install
    except ImportError:
        raise UserError("a PostgreSQL catalogue needs the psycopg driver: pip install 'guideway[postgresql]'") from None
    return sa.create_engine(u, connect_args={"connect_timeout": CONNECT_TIMEOUT_S}, pool_pre_ping=True)


def _first_line(exc: BaseException) -> str:
    text = str(getattr(exc, "orig", None) or exc).strip().splitlines()
    return text[0] if text else exc.__class__.__name__


def open_catalog(url: str | None = None, *, create: bool = True) -> Catalog:
    """Open (and with ``create`` make, if new) the catalogue at ``url`` (default: :func:`catalog_url`).

    Refuses a catalogue of a newer schema version, naming the version; a server that cannot be
    reached is one line naming its host and port and what to check."""
    u = _parsed(catalog_url(url))
    if not create and u.get_backend_name() == "sqlite" and u.database not in (None, "", ":memory:") \
            and not Path(u.database).exists():  # connecting would make an empty file
        raise UserError(f"no catalogue in {_where(u)} yet; add runs first (guideway catalog add RUN... or "
                        "--scan DIR), or check --catalog / GUIDEWAY_CATALOG")
    engine = _engine(u)
    cat = Catalog(engine, shown(u), _where(u))
    try:
        _prepare(engine, create)
    except UserError:
        engine.dispose()
        raise
    except sa.exc.OperationalError as exc:
        engine.dispose()
        if u.get_backend_name() == "sqlite":
            raise UserError(f"cannot open {_where(u)} ({_first_line(exc)}); check that the file is a "
                            "guideway catalogue and that you may read and write it") from None
        raise UserError(f"cannot reach {_where(u)} ({_first_line(exc)}); check the host name and port, that the "
                        "server is running and accepts connections from this machine, and the user, password "
                        "and database in the URL") from None
    except sa.exc.DatabaseError as exc:
        engine.dispose()
        raise UserError(f"{_where(u)} is not a usable catalogue ({_first_line(exc)}); check the URL "
                        "(docs/fleet.md)") from None
    return cat


def _stored_version(conn: Any) -> int | None:
    if not sa.inspect(conn).has_table(info_table.name):
        return None
    row = conn.execute(sa.select(info_table.c.value).where(info_table.c.key == "schema_version")).first()
    return None if row is None else int(row[0])


def _prepare(engine: Any, create: bool) -> None:
    """Check the schema version; create the tables of a new catalogue (one process at a time)."""
    for attempt in range(3):
        try:
            with engine.begin() as conn:
                if engine.dialect.name == "postgresql":
                    # two rigs creating the same new catalogue at once: the second waits for the first
                    conn.execute(sa.text("SELECT pg_advisory_xact_lock(20202020)"))
                version = _stored_version(conn)
                if version is not None and version > SCHEMA_VERSION:
                    raise UserError(f"the catalogue has schema version {version}; this guideway knows version "
                                    f"{SCHEMA_VERSION} and older: use a newer guideway with it")
                if version is None and not create:
                    raise UserError(f"no catalogue in {_where(engine.url)} yet; add runs first (guideway catalog "
                                    "add RUN... or --scan DIR), or check --catalog / GUIDEWAY_CATALOG")
                if version is None:
                    metadata.create_all(conn)
                    conn.execute(sa.insert(info_table).values(key="schema_version", value=str(SCHEMA_VERSION)))
            return
        except (sa.exc.OperationalError, sa.exc.IntegrityError) as exc:
            # SQLite: another process created the tables between our look and our CREATE; look again
            if engine.dialect.name != "sqlite" or attempt == 2 or not (
                    "already exists" in str(exc) or "UNIQUE" in str(exc)):
                raise
