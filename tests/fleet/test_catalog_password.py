"""A catalogue password is never stored nor shown: not in run.json (``setup_source`` keeps the set-up's
``[catalog] url`` without it), not in the results, not in any message, not in the TUI runs browser's title
(the ``***`` form of SQLAlchemy's ``URL.render_as_string(hide_password=True)``)."""

from __future__ import annotations

import asyncio
import json
from pathlib import Path

import pytest
from textual.widgets import Static

from fleet.catalog.config import masked_url, url_without_password
from tests.cli import ROOT, guideway
from tui.app import GuidewayApp

from .runs import straightness_summary, write_run

SECRET = "s3cret"


def test_masked_and_stored_forms() -> None:
    import sqlalchemy as sa

    for url in ("postgresql://u:s3cret@host/db", "postgresql+psycopg://guideway:s3cret@calib:5433/fleet?sslmode=require",
                "postgresql://u:s3cret@[::1]:5432/db"):
        # the form SQLAlchemy shows (its own rendering, not ours)
        assert masked_url(url) == sa.engine.make_url(url).render_as_string(hide_password=True)
    assert url_without_password("postgresql://u:s3cret@host/db") == "postgresql://u@host/db"
    assert url_without_password("postgresql://u@host/db") == "postgresql://u@host/db"
    # a password with an unescaped @ is hidden whole (SQLAlchemy would cut it at its first @)
    assert masked_url("postgresql://u:p@s3cret@host/db") == "postgresql://u:***@host/db"
    # libpq's password in the query
    assert masked_url("postgresql://u@host/db?password=s3cret&sslmode=require") == (
        "postgresql://u@host/db?password=***&sslmode=require")
    assert url_without_password("postgresql://u@host/db?password=s3cret&sslmode=require") == (
        "postgresql://u@host/db?sslmode=require")
    assert masked_url("sqlite:////data/catalog.sqlite") == "sqlite:////data/catalog.sqlite"


def test_an_acquisition_stores_and_prints_no_password(tmp_path: Path, refused_port: int,
                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    """A positioning run with a set-up whose [catalog] url holds a password (the server refuses: the run
    completes with a note): run.json, the results, the report and every printed line are free of it."""
    monkeypatch.delenv("GUIDEWAY_CATALOG", raising=False)
    text = (ROOT / "docs" / "setup-positioning.toml").read_text()
    text = text.replace("end_mm = 1000.0", "end_mm = 400.0").replace("runs = 5 ", "runs = 2 ")
    url = f"postgresql://rig:{SECRET}@127.0.0.1:{refused_port}/fleet"
    setup = tmp_path / "pos.toml"
    setup.write_text(text + f'\n[catalog]\nurl = "{url}"\n')
    run = tmp_path / "run"
    printed = []
    res = guideway("acquire", "positioning", "--setup", setup, "--out", run, "--simulate", "--auto")
    assert res.returncode == 0, res.stderr
    printed.append(res.stdout + res.stderr)
    assert "note: the run was not added to the catalogue" in res.stdout
    stored = json.loads((run / "run.json").read_text())["setup_source"]["catalog"]["url"]
    assert stored == f"postgresql://rig@127.0.0.1:{refused_port}/fleet"  # kept, without its password
    for args in (("process", run), ("report", run, "--out", tmp_path / "report.html"),
                 ("catalog", "add", run, "--catalog", url), ("catalog", "list", "--catalog", url),
                 ("catalog", "remove", run, "--catalog", url), ("trend", "--machine", "m", "--axis", "X",
                                                                "--value", "E", "--catalog", url)):
        res = guideway(*args)
        printed.append(res.stdout + res.stderr)
    assert f"cannot reach the PostgreSQL server 127.0.0.1:{refused_port}" in printed[4]  # catalog list
    for out in printed:
        assert SECRET not in out, out
    files = [p for p in [*run.rglob("*"), tmp_path / "report.html"] if p.is_file()]
    assert len(files) > 3 and [p for p in files if SECRET.encode() in p.read_bytes()] == []


def test_malformed_urls_with_a_password_are_told_without_it() -> None:
    for url in (f"postgresql://u:{SECRET}@host:abc/db", f"postgresql://u:{SECRET}@[::1/db",
                f"postgresql://u:{SECRET}@x@host/db", f"mysql://u:{SECRET}@host/db",
                f"postgresql+pg8000://u:{SECRET}@host/db"):
        res = guideway("catalog", "list", "--catalog", url)
        assert res.returncode == 2 and SECRET not in res.stdout + res.stderr, res.stderr
        assert "Traceback" not in res.stderr


def runs_title(runs_dir: Path, catalog_url: str) -> tuple[str, str]:
    """The runs browser's title while the catalogue is read and once it is."""
    seen = []

    async def main() -> None:
        app = GuidewayApp(runs_dir=runs_dir, start="runs", catalog_url=catalog_url)
        async with app.run_test(size=(120, 30)) as pilot:
            seen.append(str(app.screen.query_one("#runs-title", Static).render()))
            await app.workers.wait_for_complete()
            await pilot.pause()
            seen.append(str(app.screen.query_one("#runs-title", Static).render()))

    asyncio.run(main())
    return seen[0], seen[-1]


def test_the_runs_browser_title_hides_the_password(postgres_url: str, tmp_path: Path) -> None:
    """The test server trusts its user, so a password in the URL is accepted and ignored: the catalogue is read
    and its URL stands in the title, with *** for the password."""
    import sqlalchemy as sa

    url = sa.engine.make_url(postgres_url).set(password=SECRET).render_as_string(hide_password=False)
    assert SECRET in url
    write_run(tmp_path / "runs", "r1", summary=straightness_summary(5.0, 0.2))
    assert guideway("catalog", "add", "--scan", tmp_path / "runs", "--catalog", url).returncode == 0
    reading, read = runs_title(tmp_path / "runs", url)
    assert SECRET not in reading and SECRET not in read
    assert ":***@" in read and "1 run(s) in the catalogue" in read, read


def test_a_service_file_names_the_server_and_its_password(postgres_url: str, tmp_path: Path,
                                                          monkeypatch: pytest.MonkeyPatch) -> None:
    """The documented way without a password in the URL: a libpq service file (docs/fleet.md)."""
    import sqlalchemy as sa

    u = sa.engine.make_url(postgres_url)
    service = tmp_path / "pg_service.conf"
    service.write_text(f"[calib]\nhost={u.host}\nport={u.port}\nuser={u.username}\ndbname={u.database}\n"
                       f"password={SECRET}\n")
    monkeypatch.setenv("PGSERVICEFILE", str(service))
    write_run(tmp_path / "runs", "r1", summary=straightness_summary(5.0, 0.2))
    res = guideway("catalog", "add", "--scan", tmp_path / "runs", "--catalog", "postgresql://?service=calib")
    assert res.returncode == 0 and "1 added" in res.stdout, res.stderr
    assert SECRET not in res.stdout + res.stderr


def test_a_driver_error_quoting_the_password_is_told_without_it() -> None:
    from fleet.catalog.database import _first_line

    quoted = Exception(f'missing "=" after "{SECRET}" in connection info string\nmore')
    assert _first_line(quoted, SECRET) == 'missing "=" after "***" in connection info string'
