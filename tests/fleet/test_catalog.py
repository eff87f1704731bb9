"""``guideway catalog``: on SQLite and on a real PostgreSQL server (conftest.py)."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import pytest

from tests.cli import guideway, one_line_error

from .runs import positioning_summary, straightness_summary, write_run


def listed(url: str, *filters: str) -> list[dict]:
    res = guideway("catalog", "list", "--json", "--catalog", url, *filters)
    assert res.returncode == 0, res.stderr
    return json.loads(res.stdout)["runs"]


def test_add_list_and_add_again(catalog_url: str, tmp_path: Path) -> None:
    run = write_run(tmp_path, "r1", created="2026-03-01T10:00:00Z", summary=straightness_summary(6.0, 0.25, k=2.0),
                    tolerance={"straightness_um": 8.0, "reference_line": "minimum_zone"})
    pos = write_run(tmp_path, "p1", kind="positioning", axis="Y", created="2026-03-02T10:00:00Z",
                    summary=positioning_summary({"E": 4.5, "A": 7.0, "B": 1.0}, verdict="pass"))
    res = guideway("catalog", "add", run, pos, "--catalog", catalog_url)
    assert res.returncode == 0, res.stderr
    assert "added: " in res.stdout and "2 added" in res.stdout
    runs = listed(catalog_url)
    assert [r["path"] for r in runs] == [str(pos.resolve()), str(run.resolve())]  # newest first
    s = runs[1]
    assert set(s) == {"uid", "path", "machine", "axis", "kind", "created", "status", "values", "verdict", "options",
                      "option_defaults", "non_default_options",
                      "compensation"}
    assert s["uid"] == json.loads((run / "run.json").read_text())["uid"]
    assert (s["machine"], s["axis"], s["kind"], s["created"], s["status"]) == (
        "mill-1", "X", "straightness", "2026-03-01T10:00:00Z", "complete")
    # U (k = 2) = 0.5 in the summary: the standard uncertainty is 0.25
    assert s["values"]["minimum_zone"] == {"value_um": 6.0, "u_um": 0.25, "limit_um": 8.0}
    assert s["values"]["endpoint"] == {"value_um": 6.5, "u_um": 0.25}
    p = runs[0]
    assert p["values"]["E"] == {"value_um": 4.5, "u_um": None} and p["verdict"] == "pass"
    again = guideway("catalog", "add", run, pos, "--catalog", catalog_url)
    assert again.returncode == 0 and again.stdout.count("unchanged: ") == 2, again.stdout
    assert listed(catalog_url) == runs


def test_filters(catalog_url: str, tmp_path: Path) -> None:
    write_run(tmp_path, "a", machine="mill-1", axis="X", created="2025-06-01T00:00:00Z",
              summary=straightness_summary(5.0, 0.2))
    write_run(tmp_path, "b", machine="mill-1", axis="Y", created="2026-02-01T00:00:00Z",
              summary=straightness_summary(5.0, 0.2))
    write_run(tmp_path, "c", machine="lathe", axis="X", kind="positioning", created="2026-05-01T00:00:00Z",
              summary=positioning_summary({"E": 3.0}))
    assert guideway("catalog", "add", "--scan", tmp_path, "--catalog", catalog_url).returncode == 0
    name = lambda runs: sorted(Path(r["path"]).name for r in runs)  # noqa: E731
    assert name(listed(catalog_url, "--machine", "mill-1")) == ["a", "b"]
    assert name(listed(catalog_url, "--axis", "X")) == ["a", "c"]
    assert name(listed(catalog_url, "--kind", "positioning")) == ["c"]
    assert name(listed(catalog_url, "--since", "2026-01-01")) == ["b", "c"]
    assert name(listed(catalog_url, "--machine", "mill-1", "--axis", "X", "--since", "2025-06-01")) == ["a"]
    one_line_error(guideway("catalog", "list", "--since", "last tuesday", "--catalog", catalog_url), "--since")


def test_edited_run_is_detected_and_updated(catalog_url: str, tmp_path: Path) -> None:
    run = write_run(tmp_path, "r", summary=straightness_summary(6.0, 0.25))
    guideway("catalog", "add", run, "--catalog", catalog_url)
    with (run / "points.csv").open("a") as f:
        f.write("1,100.0\n")
    (run / "results" / "summary.json").write_text(json.dumps(straightness_summary(9.0, 0.25)))  # re-processed
    res = guideway("catalog", "add", run, "--catalog", catalog_url)
    assert res.returncode == 0
    assert "edited since it was added" in res.stdout, res.stdout
    (entry,) = listed(catalog_url)
    assert entry["values"]["minimum_zone"]["value_um"] == 9.0


def test_moved_directory_is_found_again_by_uid(catalog_url: str, tmp_path: Path) -> None:
    old = write_run(tmp_path / "runs", "r", summary=straightness_summary(6.0, 0.25))
    guideway("catalog", "add", "--scan", tmp_path / "runs", "--catalog", catalog_url)
    new = tmp_path / "archive" / "2026" / "r"
    new.parent.mkdir(parents=True)
    shutil.move(old, new)
    res = guideway("catalog", "add", "--scan", tmp_path, "--catalog", catalog_url)
    assert res.returncode == 0 and "moved: " in res.stdout, res.stdout
    (entry,) = listed(catalog_url)
    assert entry["path"] == str(new.resolve())
    # a copy next to a directory that still holds the run is not a move
    shutil.copytree(new, tmp_path / "copy")
    res = guideway("catalog", "add", tmp_path / "copy", "--catalog", catalog_url)
    assert "copy: " in res.stdout
    assert [e["path"] for e in listed(catalog_url)] == [str(new.resolve())]


def test_unreadable_run_directory_is_listed_and_the_others_added(catalog_url: str, tmp_path: Path) -> None:
    write_run(tmp_path, "good1", summary=straightness_summary(6.0, 0.25))
    write_run(tmp_path, "good2", summary=straightness_summary(7.0, 0.25))
    bad = tmp_path / "bad"
    bad.mkdir()
    (bad / "run.json").write_text("{ not json")
    res = guideway("catalog", "add", "--scan", tmp_path, "--catalog", catalog_url)
    one_line_error(res, "1 run directory could not be read")
    assert f"unreadable: {bad.resolve()}: run.json is not valid JSON" in res.stderr
    assert sorted(Path(r["path"]).name for r in listed(catalog_url)) == ["good1", "good2"]


def test_remove(catalog_url: str, tmp_path: Path) -> None:
    a = write_run(tmp_path, "a", summary=straightness_summary(6.0, 0.25))
    b = write_run(tmp_path, "b", summary=straightness_summary(6.0, 0.25))
    guideway("catalog", "add", a, b, "--catalog", catalog_url)
    assert guideway("catalog", "remove", a, "--catalog", catalog_url).returncode == 0
    uid_b = json.loads((b / "run.json").read_text())["uid"]
    assert guideway("catalog", "remove", uid_b, "--catalog", catalog_url).returncode == 0
    assert listed(catalog_url) == [] and (a / "run.json").is_file()
    one_line_error(guideway("catalog", "remove", a, "--catalog", catalog_url), "no such run in the catalogue")


def test_newer_schema_is_refused_with_its_version(catalog_url: str, tmp_path: Path) -> None:
    import sqlalchemy as sa

    run = write_run(tmp_path, "a", summary=straightness_summary(6.0, 0.25))
    guideway("catalog", "add", run, "--catalog", catalog_url)
    engine = sa.create_engine(catalog_url.replace("postgresql://", "postgresql+psycopg://"))
    with engine.begin() as conn:
        conn.execute(sa.text("UPDATE guideway_catalog SET value = '7' WHERE key = 'schema_version'"))
    engine.dispose()
    for args in (("list",), ("add", run)):
        one_line_error(guideway("catalog", *args, "--catalog", catalog_url), "schema version 7", "newer guideway")


def test_unreachable_server_is_one_line_naming_the_host(refused_port: int, tmp_path: Path) -> None:
    res = guideway("catalog", "list", "--catalog", f"postgresql://rig@127.0.0.1:{refused_port}/fleet")
    line = one_line_error(res, f"127.0.0.1:{refused_port}", "check the host name and port")
    assert "fleet" in line


def test_unsupported_url_is_refused() -> None:
    one_line_error(guideway("catalog", "list", "--catalog", "mysql://x@y/z"), "not supported")
    one_line_error(guideway("catalog", "list", "--catalog", "nonsense"), "not a database URL")


def test_default_catalogue_is_in_the_users_data_directory(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("GUIDEWAY_CATALOG", raising=False)
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path / "data"))  # the XDG base directory spec on Linux
    run = write_run(tmp_path, "a", summary=straightness_summary(6.0, 0.25))
    assert guideway("catalog", "add", run).returncode == 0
    assert (tmp_path / "data" / "guideway" / "catalog.sqlite").is_file()
    monkeypatch.setenv("GUIDEWAY_CATALOG", f"sqlite:///{tmp_path / 'env.sqlite'}")
    assert guideway("catalog", "add", run).returncode == 0
    assert (tmp_path / "env.sqlite").is_file()


def test_values_come_from_the_evaluation_of_process_when_results_are_missing_or_stale(tmp_path: Path) -> None:
    from acquisition.simulated.synthetic import simulate_run

    root = Path(__file__).resolve().parents[2]
    run, _ = simulate_run(root / "docs" / "scenario-positioning.toml", tmp_path / "pos")
    url = f"sqlite:///{tmp_path / 'c.sqlite'}"
    processed = guideway("process", run, "--json", "--no-write")
    iso = json.loads(processed.stdout)["iso230_2"]
    assert guideway("catalog", "add", run, "--catalog", url).returncode == 0
    assert not (run / "results" / "summary.json").exists()  # the catalogue writes nothing into a run
    (entry,) = listed(url)
    assert {q: v["value_um"] for q, v in entry["values"].items()} == {q: iso[q] for q in entry["values"]}
    assert set(entry["values"]) >= {"A", "E", "M", "R", "B"}
    # results older than the run's files are stale: evaluated again, not read
    second = write_run(tmp_path, "second", kind="positioning", summary=positioning_summary({"E": 999.0}))
    shutil.copy(run / "points.csv", second / "points.csv")
    meta = json.loads((run / "run.json").read_text())
    meta["uid"] = "second-run"
    (second / "run.json").write_text(json.dumps(meta))
    os.utime(second / "results" / "summary.json", ns=(1, 1))
    assert guideway("catalog", "add", second, "--catalog", url).returncode == 0
    entry = next(e for e in listed(url) if e["uid"] == "second-run")
    assert entry["values"]["E"]["value_um"] == iso["E"]


def test_created_with_an_offset_is_stored_in_utc_so_since_and_order_follow_time(catalog_url: str,
                                                                                tmp_path: Path) -> None:
    # 10:00 at +02:00 is 08:00 UTC: before 09:00 UTC, though its text sorts after "…T09:00:00Z"
    write_run(tmp_path, "east", created="2026-06-10T10:00:00+02:00", summary=straightness_summary(5.0, 0.2))
    write_run(tmp_path, "utc", created="2026-06-10T09:00:00Z", summary=straightness_summary(5.0, 0.2))
    assert guideway("catalog", "add", "--scan", tmp_path, "--catalog", catalog_url).returncode == 0
    runs = listed(catalog_url)
    assert [Path(r["path"]).name for r in runs] == ["utc", "east"]  # newest first
    assert runs[1]["created"] == "2026-06-10T08:00:00Z"
    assert [Path(r["path"]).name for r in listed(catalog_url, "--since", "2026-06-10T08:30:00Z")] == ["utc"]


def test_a_run_too_long_for_a_column_is_refused_alike_and_the_others_added(catalog_url: str, tmp_path: Path) -> None:
    # machine is varchar(255) (docs/fleet.md): PostgreSQL refused the whole batch, SQLite stored it
    write_run(tmp_path, "ok", summary=straightness_summary(5.0, 0.2))
    write_run(tmp_path, "long", machine="m" * 256, summary=straightness_summary(5.0, 0.2))
    res = guideway("catalog", "add", "--scan", tmp_path, "--catalog", catalog_url)
    one_line_error(res, "1 run directory could not be read")
    assert "machine is 256 characters long" in res.stderr and "at most 255" in res.stderr
    assert [Path(r["path"]).name for r in listed(catalog_url)] == ["ok"]


def test_a_database_failing_half_way_has_not_said_added(tmp_path: Path) -> None:
    import sqlalchemy as sa

    url = f"sqlite:///{tmp_path / 'catalog.sqlite'}"
    runs = tmp_path / "runs"
    write_run(runs, "ok", summary=straightness_summary(5.0, 0.2))
    from fleet.catalog.database import open_catalog

    with open_catalog(url):  # a new catalogue: the tables
        pass
    engine = sa.create_engine(url)
    with engine.begin() as conn:  # the database refuses the next insert, as a server going away would
        conn.execute(sa.text("CREATE TRIGGER refuse BEFORE INSERT ON guideway_runs "
                             "BEGIN SELECT RAISE(ABORT, 'refused by the test'); END"))
    engine.dispose()
    res = guideway("catalog", "add", runs / "ok", "--catalog", url)
    one_line_error(res, "refused by the test")
    assert "added:" not in res.stdout, res.stdout
    assert listed(url) == []


def test_listing_or_trending_a_catalogue_that_does_not_exist_says_so_and_creates_nothing(tmp_path: Path) -> None:
    missing = tmp_path / "typo" / "catalog.sqlite"
    url = f"sqlite:///{missing}"
    one_line_error(guideway("catalog", "list", "--catalog", url), f"no catalogue in the SQLite file {missing}",
                   "guideway catalog add")
    one_line_error(guideway("trend", "--machine", "m", "--axis", "X", "--value", "E", "--catalog", url),
                   "no catalogue in the SQLite file")
    one_line_error(guideway("catalog", "remove", tmp_path, "--catalog", url), "no catalogue")
    assert not missing.exists() and not missing.parent.exists()
    beside = tmp_path / "catalgo.sqlite"  # a typo in an existing folder: no empty catalogue left behind
    one_line_error(guideway("catalog", "list", "--catalog", f"sqlite:///{beside}"), "no catalogue in")
    assert not beside.exists()
