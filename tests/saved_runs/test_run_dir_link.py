"""A new run's directory is created exclusively and never through a link (issue 25): the default names
(``runs/demo-<UTC time>``, the TUI's ``runs/KIND-<UTC time>``) are predictable, and a symbolic link planted at
one must not make the new run be written into the link's target."""

from __future__ import annotations

from datetime import UTC, datetime, timedelta
from pathlib import Path

import pytest

from saved_runs.errors import UnsafeFileError
from saved_runs.store.lock import run_writer_lock
from saved_runs.store.writer import RunStore
from tests.cli import guideway, one_line_error


@pytest.fixture(params=["to a directory", "dangling"])
def link(request: pytest.FixtureRequest, tmp_path: Path) -> tuple[Path, Path]:
    target = tmp_path / "elsewhere"
    if request.param == "to a directory":
        target.mkdir()
    path = tmp_path / "runs" / "positioning-20991231T000000Z"
    path.parent.mkdir()
    path.symlink_to(target, target_is_directory=True)
    return path, target


def test_the_writer_lock_and_the_store_refuse_a_link_at_a_new_run(link: tuple[Path, Path]) -> None:
    path, target = link
    with pytest.raises(UnsafeFileError, match="is a symbolic link, not a new run directory"), \
            run_writer_lock(path, new=True):
        pass
    with pytest.raises(UnsafeFileError, match="is a symbolic link"):
        RunStore(path, {"kind": "straightness"}).prepare()
    assert path.is_symlink()  # left alone
    assert not target.exists() or list(target.iterdir()) == []  # nothing written into the target


def test_an_empty_directory_made_beforehand_is_still_taken(tmp_path: Path) -> None:
    out = tmp_path / "made"
    out.mkdir()
    RunStore(out, {"kind": "straightness"}).prepare()
    (out / "x").write_text("")
    with pytest.raises(Exception, match="is not empty"):
        RunStore(out, {"kind": "straightness"}).prepare()


def test_demo_refuses_a_link_planted_at_its_default_run_directory(tmp_path: Path,
                                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    """Links at every name the next 20 s would give (runs/demo-<UTC time>, one a second): refused in one line."""
    monkeypatch.chdir(tmp_path)
    target = tmp_path / "elsewhere"
    target.mkdir()
    (tmp_path / "runs").mkdir()
    now = datetime.now(UTC)
    for s in range(20):
        (tmp_path / "runs" / (now + timedelta(seconds=s)).strftime("demo-%Y%m%dT%H%M%SZ")).symlink_to(target)
    one_line_error(guideway("demo", "--stations", "3"), "is a symbolic link, not a new run directory")
    assert list(target.iterdir()) == []
