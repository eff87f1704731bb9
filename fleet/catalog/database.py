"""The catalogue's database: which one (``--catalog URL``, ``GUIDEWAY_CATALOG``, or a SQLite file in the
user's data directory), its one schema for SQLite and PostgreSQL (SQLAlchemy Core) with a version, and
opening it with one-line errors (an unreachable server, a missing driver, a newer schema).

SQLAlchemy is imported here and only here, lazily by the commands that open a catalogue, so
``guideway --help`` does not load it.  docs/fleet.md describes the schema.
"""

from __future__ import annotations

import os
import socket
import threading
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import sqlalchemy as sa

from saved_runs.errors import UserError

from .config import HIDDEN, configured_url, masked_url

SCHEMA_VERSION = 3  # raise it with every change of the tables below (and say in docs/fleet.md what changed)
CONNECT_TIMEOUT_S = 10  # a PostgreSQL server that does not answer: give up after this long
# A statement the server runs longer than this is cancelled by the server (a lock held by a stuck rig) ...
STATEMENT_TIMEOUT_S = 30
# ... and one the server has not answered this long after (the network went away: no reply ever comes) is given
# up here: the connection's socket is shut, so the waiting driver returns at once with an error.
NO_ANSWER_S = STATEMENT_TIMEOUT_S + 15

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
    # schema 2: the evaluation options of the values, JSON (entry.py); null in rows written by schema 1
    sa.Column("options_json", sa.Text, nullable=True),
    # schema 3: what the fleet overview shows of run.json besides the values, JSON (entry.py ``facts``:
    # operator, compensation state, instrument records, decision rule); null in rows written by schema 1 and 2
    sa.Column("facts_json", sa.Text, nullable=True),
    sa.Index("ix_guideway_runs_machine_axis_created", "machine", "axis", "created"),
    sa.Index("ix_guideway_runs_created", "created"),
)


# schema 3: the tolerance of a headline value per machine and axis, set with ``guideway catalog tolerance``; it
# takes the place of the runs' own [tolerance] in the fleet overview (docs/fleet.md, "Fleet overview").
tolerances_table = sa.Table(
    "guideway_tolerances", metadata,
    sa.Column("machine", sa.String(255), primary_key=True),
    sa.Column("axis", sa.String(255), primary_key=True),
    sa.Column("value", sa.String(64), primary_key=True),
    sa.Column("limit_um", sa.Float, nullable=False),  # arc-seconds on a rotary axis, as the values are
    sa.Column("set_at", sa.String(40), nullable=False),
)

# schema 3: the calibration interval of a machine axis (days), set with ``guideway catalog interval``.
intervals_table = sa.Table(
    "guideway_intervals", metadata,
    sa.Column("machine", sa.String(255), primary_key=True),
    sa.Column("axis", sa.String(255), primary_key=True),
    sa.Column("days", sa.Float, nullable=False),
    sa.Column("set_at", sa.String(40), nullable=False),
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
        raise UserError(f"catalogue URL {masked_url(url)!r} is not a database URL; use sqlite:///PATH or "
                        "postgresql://USER@HOST/DATABASE (docs/fleet.md)") from None
    except ValueError:  # SQLAlchemy reads the port as a number: "host:abc", "[::1/db" (an IPv6 host without its ])
        raise UserError(f"catalogue URL {masked_url(url)!r}: the host and port are not HOST:PORT with a number for "
                        "the port (an IPv6 address goes in brackets: postgresql://USER@[::1]:5432/DATABASE); "
                        "check the URL (docs/fleet.md)") from None
    if u.host and "@" in u.host:  # SQLAlchemy cut the user part at its first @: part of the password is the host
        raise UserError(f"catalogue URL {masked_url(url)!r}: the user name or password holds an '@'; write it as "
                        "%40 in the URL, or leave the password out of the URL (~/.pgpass, PGPASSWORD)")
    backend = u.get_backend_name()
    if backend == "postgres" or (backend == "postgresql" and u.drivername == "postgresql"):
        u = u.set(drivername="postgresql+psycopg")
    elif backend not in ("sqlite", "postgresql"):
        raise UserError(f"catalogue URL {shown(u)}: {backend} databases are not supported; use sqlite:///PATH or "
                        "postgresql://USER@HOST/DATABASE (docs/fleet.md)")
    return u


def shown(u: Any) -> str:
    """A URL as it may be printed: its password as *** (a ``?password=`` in its query too)."""
    return masked_url(u.render_as_string(hide_password=True) if hasattr(u, "render_as_string") else str(u))


def _where(u: Any) -> str:
    """What an error names: the file of a SQLite catalogue, host and port of a server."""
    if u.get_backend_name() == "sqlite":
        return f"the SQLite file {u.database}"
    return f"the PostgreSQL server {u.host or 'localhost'}:{u.port or 5432} (database {u.database or '?'})"


class _Watchdog:
    """Gives up on a PostgreSQL server that has not answered a statement or a commit within ``NO_ANSWER_S``
    (a network that went away sends no error and no reply: the driver would wait for ever).  Armed before each
    statement and commit, disarmed after it; on firing it shuts the connection's socket, so that the driver
    returns with "server closed the connection" and the command ends with one line."""

    def __init__(self, seconds: float) -> None:
        self.seconds = seconds
        self.fired = False
        self._timers: dict[int, threading.Timer] = {}
        self._lock = threading.Lock()

    def arm(self, dbapi_conn: Any) -> None:
        self.disarm(dbapi_conn)
        timer = threading.Timer(self.seconds, self._fire, (dbapi_conn,))
        timer.daemon = True
        with self._lock:
            self._timers[id(dbapi_conn)] = timer
        timer.start()

    def disarm(self, dbapi_conn: Any) -> None:
        with self._lock:
            timer = self._timers.pop(id(dbapi_conn), None)
        if timer is not None:
            timer.cancel()

    def _fire(self, dbapi_conn: Any) -> None:
        with self._lock:
            if self._timers.pop(id(dbapi_conn), None) is None:
                return  # disarmed meanwhile
            try:
                fd = _socket_fd(dbapi_conn)
                if fd is None:
                    return
                self.fired = True
                with socket.socket(fileno=os.dup(fd)) as sock:  # a second handle: shutting it shuts the connection
                    sock.shutdown(socket.SHUT_RDWR)
            except (OSError, ValueError, AttributeError):
                pass  # closed meanwhile

    def watch(self, engine: Any) -> None:
        """Arm and disarm around every statement and commit of ``engine``'s connections."""
        from sqlalchemy import event

        def dbapi(conn: Any) -> Any:
            return conn.connection.dbapi_connection

        event.listen(engine, "before_cursor_execute", lambda conn, *a: self.arm(dbapi(conn)))
        event.listen(engine, "after_cursor_execute", lambda conn, *a: self.disarm(dbapi(conn)))
        event.listen(engine, "commit", lambda conn: self.arm(dbapi(conn)))
        event.listen(engine, "handle_error", lambda ctx: self.disarm_all())
        # a connection given back is reset (a ROLLBACK sent to the server after a read), then checked in
        event.listen(engine, "reset", lambda dbapi_conn, record, state: self.arm(dbapi_conn))
        event.listen(engine, "checkin", lambda dbapi_conn, record: self.disarm(dbapi_conn))

    def disarm_all(self) -> None:
        with self._lock:
            timers, self._timers = list(self._timers.values()), {}
        for t in timers:
            t.cancel()


def _socket_fd(dbapi_conn: Any) -> int | None:
    """The socket of a psycopg 3 (or psycopg2) connection, None when closed or not known."""
    if getattr(dbapi_conn, "closed", False):
        return None
    pgconn = getattr(dbapi_conn, "pgconn", None)
    if pgconn is not None:
        return int(pgconn.socket)
    fileno = getattr(dbapi_conn, "fileno", None)
    return int(fileno()) if callable(fileno) else None


@dataclass
class Catalog:
    """An open catalogue: its SQLAlchemy engine, the URL as shown to people, and whether it is SQLite."""

    engine: Any
    url: str
    where: str = ""
    watchdog: _Watchdog | None = field(default=None, repr=False)
    secret: str | None = field(default=None, repr=False)  # the URL's password: never in a message

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
            where = self.where or self.url
            if self.watchdog is not None and self.watchdog.fired:
                raise UserError(f"no answer from {where} for {self.watchdog.seconds:g} s (the network or the server "
                                "went away); check the network and the server and run the command again (what was "
                                "written before stays)") from None
            if self.dialect == "sqlite":
                raise UserError(f"{where} failed: {_first_line(exc, self.secret)}; check the free space of its "
                                "disk and that you may write the file, and run the command again (what was written "
                                "before stays)") from None
            raise UserError(f"the catalogue at {where} failed: {_first_line(exc, self.secret)}; check the "
                            "server and run the command again (what was written before stays)") from None


def _engine(u: Any) -> tuple[Any, _Watchdog | None]:
    """The engine of ``u`` and, for PostgreSQL, the watchdog of its statements."""
    if u.get_backend_name() == "sqlite":
        if u.database and u.database != ":memory:":
            path = Path(u.database).expanduser()
            try:
                path.parent.mkdir(parents=True, exist_ok=True)
            except OSError as exc:
                raise UserError(f"cannot create the folder of the catalogue file {path} ({exc.strerror}); "
                                "check the path or give another with --catalog sqlite:///PATH") from None
        # several processes may add at once: wait for the file lock rather than fail at once
        return sa.create_engine(u, connect_args={"timeout": 60}), None
    if u.get_driver_name() in ASYNC_DRIVERS:
        raise UserError(f"catalogue URL {shown(u)}: {u.drivername} is an asyncio driver, which guideway cannot use; "
                        "write postgresql://... (the psycopg 3 driver) instead")
    args: dict[str, Any] = {}
    if u.get_driver_name() in ("psycopg", "psycopg2"):  # libpq's: connecting, and a network gone silent
        args = {"connect_timeout": CONNECT_TIMEOUT_S, "keepalives": 1, "keepalives_idle": 10,
                "keepalives_interval": 5, "keepalives_count": 3, "tcp_user_timeout": NO_ANSWER_S * 1000,
                # after the URL's own ?options= (connect_args replace the URL's keys: keep them)
                "options": " ".join([*([str(u.query["options"])] if "options" in u.query else []),
                                     f"-c statement_timeout={STATEMENT_TIMEOUT_S * 1000}"])}
    try:
        # no pool_pre_ping: its ping bypasses the statement events, so the watchdog would not cover it (a
        # connection that died in the pool fails at its next statement instead, with one line)
        engine = sa.create_engine(u, connect_args=args)
    except ImportError as exc:
        if u.drivername == "postgresql+psycopg":
            raise UserError("a PostgreSQL catalogue needs the psycopg driver, which is not installed: "
                            "pip install 'guideway[postgresql]'") from None
        raise UserError(f"a catalogue at {shown(u)} needs the {u.get_driver_name()} driver, which is not installed: "
                        f"pip install {exc.name or u.get_driver_name()}, or write postgresql://... for psycopg 3 "
                        "(pip install 'guideway[postgresql]')") from None
    watchdog = _Watchdog(NO_ANSWER_S)
    watchdog.watch(engine)
    return engine, watchdog


ASYNC_DRIVERS = ("asyncpg", "psycopg_async", "aiosqlite")


def _first_line(exc: BaseException, secret: str | None = None) -> str:
    """The first line of a driver's error, with the URL's password (``secret``) as *** should the driver quote
    it (a connection string it could not read)."""
    text = str(getattr(exc, "orig", None) or exc).strip().splitlines()
    line = text[0] if text else exc.__class__.__name__
    return line.replace(secret, HIDDEN) if secret else line


def open_catalog(url: str | None = None, *, create: bool = True) -> Catalog:
    """Open (and with ``create`` make, if new) the catalogue at ``url`` (default: :func:`catalog_url`).

    Refuses a catalogue of a newer schema version, naming the version; a server that cannot be
    reached is one line naming its host and port and what to check."""
    u = _parsed(catalog_url(url))
    if not create and u.get_backend_name() == "sqlite" and u.database not in (None, "", ":memory:") \
            and not Path(u.database).exists():  # connecting would make an empty file
        raise UserError(f"no catalogue in {_where(u)} yet; add runs first (guideway catalog add RUN... or "
                        "--scan DIR), or check --catalog / GUIDEWAY_CATALOG")
    if create and u.get_backend_name() == "sqlite":
        _create_sqlite(u)
    engine, watchdog = _engine(u)
    cat = Catalog(engine, shown(u), _where(u), watchdog, u.password)
    try:
        _prepare(engine, create)
    except UserError:
        engine.dispose()
        raise
    except sa.exc.OperationalError as exc:
        engine.dispose()
        if watchdog is not None and watchdog.fired:
            raise UserError(f"no answer from {_where(u)} for {watchdog.seconds:g} s (the network or the server went "
                            "away); check the network and the server and run the command again") from None
        if u.get_backend_name() == "sqlite":
            raise UserError(f"cannot open {_where(u)} ({_first_line(exc, u.password)}); check that the file is a "
                            "guideway catalogue and that you may read and write it") from None
        raise UserError(f"cannot reach {_where(u)} ({_first_line(exc, u.password)}); check the host name and port, "
                        "that the server is running and accepts connections from this machine, and the user, "
                        "password and database in the URL") from None
    except sa.exc.DatabaseError as exc:
        engine.dispose()
        raise UserError(f"{_where(u)} is not a usable catalogue ({_first_line(exc, u.password)}); check the URL "
                        "(docs/fleet.md)") from None
    return cat


def _create_sqlite(u: Any) -> None:
    """Make a new SQLite catalogue whole or not at all: its tables are made in a file of its own next to it,
    which takes the catalogue's name only when complete (a full disk half way would otherwise leave an empty
    or broken file that the next command takes for a catalogue)."""
    if u.database in (None, "", ":memory:"):
        return
    path = Path(u.database)  # as SQLite opens it
    if path.exists():
        return
    engine, _ = _engine(u)  # makes the folder, with its one-line error
    engine.dispose()
    new = path.with_name(f".{path.name}.{os.getpid()}.new")
    engine, _ = _engine(u.set(database=str(new)))
    try:
        _prepare(engine, True)
        engine.dispose()
        try:
            os.link(new, path)  # only if no other process made it meanwhile (then its file is taken)
        except FileExistsError:
            pass
        except OSError:  # a file system without hard links
            if not path.exists():
                os.replace(new, path)
    except (sa.exc.DBAPIError, OSError) as exc:
        engine.dispose()
        why = _first_line(exc, u.password) if isinstance(exc, sa.exc.DBAPIError) else (exc.strerror or str(exc))
        raise UserError(f"cannot create {_where(u)} ({why}); check the free space of its disk and that you may "
                        "write there, and run the command again (no catalogue file was left)") from None
    finally:
        for leftover in (new, new.with_name(new.name + "-journal")):
            leftover.unlink(missing_ok=True)


def _stored_version(conn: Any) -> int | None:
    if not sa.inspect(conn).has_table(info_table.name):
        return None
    row = conn.execute(sa.select(info_table.c.value).where(info_table.c.key == "schema_version")).first()
    if row is None:
        return None
    try:
        return int(row[0])
    except (TypeError, ValueError):
        raise UserError(f"the catalogue's schema_version is {row[0]!r}, not a number: this is not a guideway "
                        "catalogue or it is damaged; check the URL, or rebuild the catalogue from the run directories "
                        "(guideway catalog add --scan DIR) into a new one") from None


def _migrate(conn: Any, version: int) -> None:
    """Bring the tables of an older ``version`` up to :data:`SCHEMA_VERSION` (each step may be met half done: a
    SQLite ``ALTER TABLE`` commits on its own)."""
    if version < 2:  # schema 2: the evaluation options of each entry (null: written by schema 1)
        columns = {c["name"] for c in sa.inspect(conn).get_columns(runs_table.name)}
        if "options_json" not in columns:
            conn.execute(sa.text(f"ALTER TABLE {runs_table.name} ADD COLUMN options_json TEXT"))
    if version < 3:  # schema 3: the tolerances and intervals kept per machine axis, and each entry's facts
        columns = {c["name"] for c in sa.inspect(conn).get_columns(runs_table.name)}
        if "facts_json" not in columns:
            conn.execute(sa.text(f"ALTER TABLE {runs_table.name} ADD COLUMN facts_json TEXT"))
        metadata.create_all(conn, tables=[tolerances_table, intervals_table], checkfirst=True)
    conn.execute(sa.update(info_table).where(info_table.c.key == "schema_version")
                 .values(value=str(SCHEMA_VERSION)))


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
                elif version < SCHEMA_VERSION:
                    _migrate(conn, version)
            return
        except (sa.exc.OperationalError, sa.exc.IntegrityError) as exc:
            # SQLite: another process created (or migrated) the tables between our look and our CREATE; look again
            if engine.dialect.name != "sqlite" or attempt == 2 or not (
                    "already exists" in str(exc) or "UNIQUE" in str(exc) or "duplicate column" in str(exc)):
                raise
