"""The catalogue meeting bad names, bad URLs, a damaged catalogue, a network that goes silent and a full disk:
one line each (exit 2), never a traceback, and nothing left that a later command takes for a catalogue."""

from __future__ import annotations

import json
import socket
import subprocess
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

import fleet.catalog.database as database
from tests.cli import guideway, one_line_error

from .runs import straightness_summary, write_run


def listed(url: str) -> list[dict]:
    res = guideway("catalog", "list", "--json", "--catalog", url)
    assert res.returncode == 0, res.stderr
    return json.loads(res.stdout)["runs"]


def test_a_nul_in_a_name_is_one_unreadable_run(catalog_url: str, tmp_path: Path) -> None:
    """PostgreSQL text holds no NUL: the run is listed as unreadable on both databases, the others are added."""
    runs = tmp_path / "runs"
    write_run(runs, "a", created="2026-01-01T00:00:00Z", summary=straightness_summary(5.0, 0.2))
    write_run(runs, "b", machine="mill\0one", created="2026-01-02T00:00:00Z", summary=straightness_summary(5.0, 0.2))
    write_run(runs, "c", axis="X\0", created="2026-01-03T00:00:00Z", summary=straightness_summary(5.0, 0.2))
    write_run(runs, "d", created="2026-01-04T00:00:00Z", summary=straightness_summary(5.0, 0.2))
    res = guideway("catalog", "add", "--scan", runs, "--catalog", catalog_url)
    one_line_error(res, "2 run directories could not be read")
    assert f"unreadable: {(runs / 'b').resolve()}: run.json machine holds a NUL character" in res.stderr
    assert f"unreadable: {(runs / 'c').resolve()}: run.json axis holds a NUL character" in res.stderr
    assert res.stdout.count("added: ") == 2
    assert sorted(Path(r["path"]).name for r in listed(catalog_url)) == ["a", "d"]


def test_list_escapes_control_characters(catalog_url: str, tmp_path: Path) -> None:
    write_run(tmp_path / "runs", "evil", machine="m\x1b[2J\x1b[31mred", axis="X\nforged line",
              summary=straightness_summary(5.0, 0.2))
    assert guideway("catalog", "add", "--scan", tmp_path / "runs", "--catalog", catalog_url).returncode == 0
    res = guideway("catalog", "list", "--catalog", catalog_url)
    assert res.returncode == 0, res.stderr
    assert "\x1b" not in res.stdout and len(res.stdout.splitlines()) == 1  # one entry, one line
    assert "m\\x1b[2J\\x1b[31mred" in res.stdout and "X\\nforged line" in res.stdout
    # --json keeps the names as they are (JSON escapes them itself)
    assert listed(catalog_url)[0]["axis"] == "X\nforged line"


@pytest.mark.parametrize(("url", "says"), [
    ("postgresql://u@calib:abc/db", "not HOST:PORT with a number for the port"),
    ("postgresql://u@[::1/db", "an IPv6 address goes in brackets"),
    ("postgresql+asyncpg://u@calib/db", "asyncio driver"),
    ("postgresql+pg8000://u@calib/db", "needs the pg8000 driver, which is not installed: pip install pg8000"),
])
def test_bad_urls_are_one_line(url: str, says: str) -> None:
    pytest.importorskip("sqlalchemy")
    if "pg8000" in url:
        try:
            import pg8000  # noqa: F401
            pytest.skip("pg8000 is installed here")
        except ImportError:
            pass
    for command in (("catalog", "list"), ("catalog", "add", "--scan", ".")):
        one_line_error(guideway(*command, "--catalog", url), says)


def test_a_missing_psycopg_is_one_line(monkeypatch: pytest.MonkeyPatch) -> None:
    import sys

    for name in [m for m in sys.modules if m == "psycopg" or m.startswith("psycopg.")]:
        monkeypatch.delitem(sys.modules, name)
    monkeypatch.setitem(sys.modules, "psycopg", None)  # import psycopg: ImportError, as when not installed
    one_line_error(guideway("catalog", "list", "--catalog", "postgresql://u@calib/db"),
                   "needs the psycopg driver, which is not installed: pip install 'guideway[postgresql]'")


def test_a_schema_version_that_is_no_number(catalog_url: str, tmp_path: Path) -> None:
    write_run(tmp_path / "runs", "a", summary=straightness_summary(5.0, 0.2))
    assert guideway("catalog", "add", "--scan", tmp_path / "runs", "--catalog", catalog_url).returncode == 0
    import sqlalchemy as sa

    engine = sa.create_engine(catalog_url.replace("postgresql://", "postgresql+psycopg://"))
    with engine.begin() as conn:
        conn.execute(sa.text("UPDATE guideway_catalog SET value = 'two' WHERE key = 'schema_version'"))
    engine.dispose()
    one_line_error(guideway("catalog", "list", "--catalog", catalog_url), "schema_version is 'two', not a number")


def test_a_sqlite_failure_names_the_file_not_a_server(tmp_path: Path) -> None:
    url = f"sqlite:///{tmp_path / 'c.sqlite'}"
    write_run(tmp_path / "runs", "a", summary=straightness_summary(5.0, 0.2))
    assert guideway("catalog", "add", "--scan", tmp_path / "runs", "--catalog", url).returncode == 0
    import sqlite3

    with sqlite3.connect(tmp_path / "c.sqlite") as conn:  # every write now fails as a full disk would
        conn.execute("CREATE TRIGGER full BEFORE INSERT ON guideway_runs BEGIN SELECT RAISE(ABORT, "
                     "'database or disk is full'); END")
    write_run(tmp_path / "runs", "b", summary=straightness_summary(5.0, 0.2))
    line = one_line_error(guideway("catalog", "add", "--scan", tmp_path / "runs", "--catalog", url),
                          f"the SQLite file {tmp_path / 'c.sqlite'} failed: database or disk is full",
                          "check the free space of its disk")
    assert "server" not in line


def test_schema_1_is_migrated_and_its_entries_written_again(catalog_url: str, tmp_path: Path) -> None:
    """A catalogue of schema 1 (no options column) is brought to schema 2 when opened; adding its runs again
    writes their options (and the verdict of today's evaluation)."""
    import sqlalchemy as sa

    run = write_run(tmp_path / "runs", "a", summary=straightness_summary(5.0, 0.2))
    assert guideway("catalog", "add", run, "--catalog", catalog_url).returncode == 0
    engine = sa.create_engine(catalog_url.replace("postgresql://", "postgresql+psycopg://"))
    with engine.begin() as conn:  # as guideway with schema 1 left it
        conn.execute(sa.text("ALTER TABLE guideway_runs DROP COLUMN options_json"))
        conn.execute(sa.text("UPDATE guideway_catalog SET value = '1' WHERE key = 'schema_version'"))
    engine.dispose()
    (old,) = listed(catalog_url)
    assert old["options"] is None and old["values"]["minimum_zone"]["value_um"] == 5.0
    assert "evaluation options not recorded" in guideway("catalog", "list", "--catalog", catalog_url).stdout
    res = guideway("catalog", "add", run, "--catalog", catalog_url)
    assert res.returncode == 0 and "written by an older guideway" in res.stdout, res.stdout
    assert listed(catalog_url)[0]["options"] is not None
    engine = sa.create_engine(catalog_url.replace("postgresql://", "postgresql+psycopg://"))
    with engine.connect() as conn:
        assert conn.execute(sa.text("SELECT value FROM guideway_catalog")).scalar() == str(database.SCHEMA_VERSION)
    engine.dispose()


class SilentProxy:
    """A TCP proxy on 127.0.0.1 to ``port`` that goes silent, as a network that went away, once the client
    sends ``trigger``: from then on nothing is forwarded either way, and the sockets stay open (no reset, no
    end of stream: the client hears nothing at all)."""

    def __init__(self, port: int, trigger: bytes) -> None:
        self.target, self.trigger = port, trigger
        self.silent = threading.Event()
        self.listener = socket.create_server(("127.0.0.1", 0))
        self.port = self.listener.getsockname()[1]
        self.sockets: list[socket.socket] = [self.listener]
        threading.Thread(target=self._accept, daemon=True).start()

    def _accept(self) -> None:
        while True:
            try:
                client, _ = self.listener.accept()
            except OSError:
                return
            server = socket.create_connection(("127.0.0.1", self.target))
            self.sockets += [client, server]
            threading.Thread(target=self._pump, args=(client, server, True), daemon=True).start()
            threading.Thread(target=self._pump, args=(server, client, False), daemon=True).start()

    def _pump(self, src: socket.socket, dst: socket.socket, from_client: bool) -> None:
        while True:
            try:
                data = src.recv(65536)
            except OSError:
                return
            if not data:
                return
            if from_client and self.trigger in data:
                self.silent.set()
            if not self.silent.is_set():
                try:
                    dst.sendall(data)
                except OSError:
                    return

    def close(self) -> None:
        for s in self.sockets:
            s.close()


@pytest.fixture
def silent_proxy(postgres_url: str) -> Iterator[tuple[SilentProxy, str]]:
    import sqlalchemy as sa

    u = sa.engine.make_url(postgres_url)
    proxy = SilentProxy(int(u.port), b"INSERT INTO guideway_runs")
    yield proxy, u.set(port=proxy.port).render_as_string(hide_password=False)
    proxy.close()


def test_a_network_gone_silent_during_add_is_one_line(silent_proxy: tuple[SilentProxy, str], tmp_path: Path,
                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    proxy, url = silent_proxy
    guideway("catalog", "add", "--scan", tmp_path, "--catalog", url)  # the tables, through the proxy
    monkeypatch.setattr(database, "NO_ANSWER_S", 2)
    write_run(tmp_path / "runs", "a", summary=straightness_summary(5.0, 0.2))
    start = time.monotonic()
    res = guideway("catalog", "add", "--scan", tmp_path / "runs", "--catalog", url)
    took = time.monotonic() - start
    assert proxy.silent.is_set()  # the INSERT went into the void
    one_line_error(res, f"no answer from the PostgreSQL server 127.0.0.1:{proxy.port}", "for 2 s",
                   "check the network and the server")
    assert "added: " not in res.stdout
    assert took < 10, took


def test_the_statement_timeout_and_the_socket_options_are_set(postgres_url: str) -> None:
    """What bounds a real network drop that the proxy above cannot show (no TCP acknowledgement at all):
    libpq's keepalives and TCP_USER_TIMEOUT, and the server's statement_timeout, as the server sees them."""
    import sqlalchemy as sa

    with database.open_catalog(postgres_url) as cat, cat.engine.connect() as conn:
        assert conn.execute(sa.text("SHOW statement_timeout")).scalar() == f"{database.STATEMENT_TIMEOUT_S}s"
        params = conn.connection.dbapi_connection.info.get_parameters()
    assert params["keepalives"] == "1" and params["tcp_user_timeout"] == str(database.NO_ANSWER_S * 1000)
    # the URL's own server options are kept beside the statement timeout
    with database.open_catalog(postgres_url + "?options=-c%20lock_timeout%3D5000") as cat, \
            cat.engine.connect() as conn:
        assert conn.execute(sa.text("SHOW lock_timeout")).scalar() == "5s"
        assert conn.execute(sa.text("SHOW statement_timeout")).scalar() == f"{database.STATEMENT_TIMEOUT_S}s"


def test_no_watch_is_left_armed(postgres_url: str, tmp_path: Path) -> None:
    """Every statement, commit and reset is watched only while it waits for the server: none is left armed
    (a watch left armed would shut a connection kept in the pool)."""
    from fleet.catalog.runs import add_runs, list_entries

    write_run(tmp_path / "runs", "a", summary=straightness_summary(5.0, 0.2))
    with database.open_catalog(postgres_url) as cat:
        assert cat.watchdog is not None and not cat.watchdog._timers
        assert [o.action for o in add_runs(cat, [tmp_path / "runs" / "a"])] in (["added"], ["unchanged"])
        assert not cat.watchdog._timers
        assert list_entries(cat)
        assert not cat.watchdog._timers and not cat.watchdog.fired


def test_a_full_disk_at_the_first_add_leaves_no_catalogue_file(tmp_path: Path) -> None:
    """A 8 KiB tmpfs: too small for the tables of a new catalogue (SQLite: "database or disk is full")."""
    mnt = tmp_path / "full"
    mnt.mkdir()
    res = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=8k", "tmpfs", str(mnt)], capture_output=True)
    if res.returncode:
        pytest.skip(f"mounting a tmpfs is not permitted here: {res.stderr.decode().strip()}")
    try:
        url = f"sqlite:///{mnt / 'catalog.sqlite'}"
        write_run(tmp_path / "runs", "a", summary=straightness_summary(5.0, 0.2))
        one_line_error(guideway("catalog", "add", "--scan", tmp_path / "runs", "--catalog", url),
                       f"cannot create the SQLite file {mnt / 'catalog.sqlite'}", "full",
                       "no catalogue file was left")
        assert list(mnt.iterdir()) == []
        one_line_error(guideway("catalog", "list", "--catalog", url), "no catalogue in the SQLite file")
    finally:
        subprocess.run(["umount", str(mnt)], check=True)


def test_a_failure_while_making_a_new_catalogue_leaves_no_file(tmp_path: Path, monkeypatch: pytest.MonkeyPatch
                                                               ) -> None:
    """The same, wherever a tmpfs cannot be mounted: the tables' creation fails as a full disk makes it fail."""
    import sqlalchemy as sa

    def full(*args: object, **kwargs: object) -> None:
        raise sa.exc.OperationalError("CREATE TABLE guideway_runs", {}, Exception("database or disk is full"))

    monkeypatch.setattr(database.metadata, "create_all", full)
    url = f"sqlite:///{tmp_path / 'cat' / 'catalog.sqlite'}"
    write_run(tmp_path / "runs", "a", summary=straightness_summary(5.0, 0.2))
    one_line_error(guideway("catalog", "add", "--scan", tmp_path / "runs", "--catalog", url),
                   "database or disk is full", "no catalogue file was left")
    assert list((tmp_path / "cat").iterdir()) == []
    monkeypatch.undo()
    assert guideway("catalog", "add", "--scan", tmp_path / "runs", "--catalog", url).returncode == 0  # room again
    assert len(listed(url)) == 1
