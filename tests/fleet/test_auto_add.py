"""A completed acquisition adds itself to the catalogue configured by the set-up's ``[catalog] url`` or
``GUIDEWAY_CATALOG``; none is written when neither is set; an unreachable one costs a note, not the run."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.cli import guideway
from tests.setups import straightness_setup_text


def acquire(tmp_path: Path, name: str, extra: str = "") -> tuple[int, str, Path]:
    setup = tmp_path / f"{name}.toml"
    setup.write_text(straightness_setup_text(stations=4, samples=1) + extra)
    out = tmp_path / name
    res = guideway("acquire", "straightness", "--setup", setup, "--out", out, "--simulate", "--auto")
    assert res.returncode == 0, res.stderr
    return res.returncode, res.stdout, out


def uids(url: str) -> list[str]:
    res = guideway("catalog", "list", "--json", "--catalog", url)
    return [r["uid"] for r in json.loads(res.stdout)["runs"]]


def test_completed_run_adds_itself(catalog_url: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("GUIDEWAY_CATALOG", raising=False)
    _, out, run = acquire(tmp_path, "by-setup", f'\n[catalog]\nurl = "{catalog_url}"\n')
    assert "catalogue " in out and "added: " in out
    uid = json.loads((run / "run.json").read_text())["uid"]
    assert uids(catalog_url) == [uid]
    (entry,) = json.loads(guideway("catalog", "list", "--json", "--catalog", catalog_url).stdout)["runs"]
    assert entry["status"] == "complete" and entry["values"]["minimum_zone"]["u_um"] > 0


def test_environment_variable_or_nothing(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("GUIDEWAY_CATALOG", raising=False)
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path / "data"))
    _, out, _ = acquire(tmp_path, "none")
    assert "catalogue" not in out and not (tmp_path / "data").exists()  # not configured: no default file
    url = f"sqlite:///{tmp_path / 'env.sqlite'}"
    monkeypatch.setenv("GUIDEWAY_CATALOG", url)
    _, out, run = acquire(tmp_path, "by-env")
    assert uids(url) == [json.loads((run / "run.json").read_text())["uid"]]


def test_unreachable_catalogue_costs_a_note_not_the_run(tmp_path: Path, refused_port: int,
                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("GUIDEWAY_CATALOG", f"postgresql://rig@127.0.0.1:{refused_port}/fleet")
    code, out, run = acquire(tmp_path, "offline")
    assert code == 0 and (run / "points.csv").is_file()
    note = "note: the run was not added to the catalogue (cannot reach the PostgreSQL server 127.0.0.1:"
    assert f"{note}{refused_port}" in out and f"guideway catalog add {run}" in out


def test_catalog_table_is_checked_with_the_setup(tmp_path: Path) -> None:
    setup = tmp_path / "s.toml"
    setup.write_text(straightness_setup_text(stations=4, samples=1) + '\n[catalog]\nuri = "x"\n')
    res = guideway("acquire", "straightness", "--setup", setup, "--out", tmp_path / "r", "--simulate", "--auto")
    assert res.returncode == 2 and "uri" in res.stderr
