"""The runs browser with the fleet tools: two marked runs compared (older as A), and, with a catalogue
configured, the catalogue's runs filtered by machine and axis and the trend of the selected run's axis."""

from __future__ import annotations

import asyncio
import uuid
from pathlib import Path
from typing import Any

from tests.cli import guideway
from tests.tui.test_runs_screen import copy_run
from tui.app import GuidewayApp
from tui.screens.compare import CompareScreen
from tui.screens.runs import RunsScreen
from tui.screens.trend import TrendScreen


def positioning_runs(folder: Path, machines: dict[str, str], created: dict[str, str] | None = None
                     ) -> dict[str, Path]:
    """Copies of the saved positioning run, each its own run (uid), on the machine given, one month
    apart in the order given (or ``created`` as given by name)."""
    out = {}
    for i, (name, machine) in enumerate(machines.items()):
        when = (created or {}).get(name, f"2026-0{i + 1}-01T00:00:00Z")
        copied = copy_run("positioning-x", folder / f".copy{i}", uid=uuid.uuid4().hex, machine=machine,
                          created=when)
        out[name] = copied.rename(folder / name)
        copied.parent.rmdir()
    return out


def drive(runs_dir: Path, keys: tuple[str, ...], catalog_url: str | None = None) -> list[Any]:
    """Press ``keys`` on the runs browser; return what the app shows after each key: (screen, shown
    runs' names, footer keys offered, the line under the table)."""
    seen: list[Any] = []

    async def main() -> None:
        app = GuidewayApp(runs_dir=runs_dir, start="runs", catalog_url=catalog_url)
        async with app.run_test(size=(100, 30)) as pilot:
            for k in ("", *keys):
                if k:
                    await pilot.press(k)
                await pilot.pause()
                await app.workers.wait_for_complete()
                await pilot.pause()
                screen = app.screen
                runs = [r.path.name for r in screen.runs] if isinstance(screen, RunsScreen) else []
                offered = ({k for k, b in app.active_bindings.items() if b.enabled} if isinstance(screen, RunsScreen)
                           else set())
                detail = str(screen.query_one("#run-detail").render()) if isinstance(screen, RunsScreen) else ""
                seen.append((screen, runs, offered, detail))

    asyncio.run(main())
    return seen


def test_two_marked_runs_are_compared_the_older_as_a(tmp_path: Path) -> None:
    runs = positioning_runs(tmp_path, {"before": "m1", "after": "m1"})
    # newest first: "after" is row 0; mark it, then "before", then compare
    seen = drive(tmp_path, ("space", "down", "space", "x"))
    first, *_, marked_two, compared = seen
    assert "x" not in first[2] and "t" not in first[2] and "m" not in first[2]  # no catalogue, nothing marked
    assert "x" in marked_two[2]
    screen = compared[0]
    assert isinstance(screen, CompareScreen)
    assert (screen.run_a, screen.run_b) == (runs["before"], runs["after"])


def test_a_third_mark_replaces_the_oldest(tmp_path: Path) -> None:
    positioning_runs(tmp_path, {"a": "m1", "b": "m1", "c": "m1"})
    seen = drive(tmp_path, ("space", "down", "space", "down", "space"))
    screen = seen[-1][0]
    assert [p.name for p in screen.marked] == ["b", "a"]  # c (marked first) gave way


def test_the_catalogue_is_listed_filtered_and_trended(tmp_path: Path) -> None:
    folder = tmp_path / "runs"
    folder.mkdir()
    positioning_runs(folder, {"x1": "mill", "x2": "mill", "l1": "lathe"})
    url = f"sqlite:///{tmp_path / 'catalog.sqlite'}"
    assert guideway("catalog", "add", "--scan", folder, "--catalog", url).returncode == 0
    elsewhere = tmp_path / "empty"  # the browser's folder holds nothing: the rows come from the catalogue
    elsewhere.mkdir()
    seen = drive(elsewhere, ("m", "m", "t"), catalog_url=url)
    listed, lathe, mill, trend = seen
    assert listed[1] == ["l1", "x2", "x1"]  # newest first
    assert "complete when catalogued, at " + str(folder / "l1") in listed[3]  # not "0 points on disk"
    assert {"t", "m", "a", "l"} <= listed[2]
    assert lathe[1] == ["l1"] and mill[1] == ["x2", "x1"]  # machines in sorted order: lathe, then mill
    screen = trend[0]
    assert isinstance(screen, TrendScreen)
    assert (screen.machine, screen.axis, screen.value) == ("mill", "X", "E")


def test_l_switches_to_the_folder_and_an_unreadable_catalogue_falls_back_to_it(tmp_path: Path) -> None:
    positioning_runs(tmp_path, {"here": "m1"})
    url = f"sqlite:///{tmp_path / 'nowhere' / 'catalog.sqlite'}"  # a folder that does not exist
    seen = drive(tmp_path, (), catalog_url=url)
    screen, runs, offered, _ = seen[-1]
    assert runs == ["here"] and screen.catalog_problem and "t" not in offered


def test_the_older_is_a_by_time_when_created_has_an_offset(tmp_path: Path) -> None:
    # 10:00 at +02:00 is 08:00 UTC, an hour before 09:00Z, though its text sorts after it
    runs = positioning_runs(tmp_path, {"before": "m1", "after": "m1"},
                            created={"before": "2026-03-01T10:00:00+02:00", "after": "2026-03-01T09:00:00Z"})
    screen = drive(tmp_path, ("space", "down", "space", "x"))[-1][0]
    assert isinstance(screen, CompareScreen)
    assert (screen.run_a, screen.run_b) == (runs["before"], runs["after"])
