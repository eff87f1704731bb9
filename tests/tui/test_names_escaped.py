"""Names from a run.json shown as text, never as terminal codes or markup (issue 25): a machine, axis, operator
or run name with a newline, an ESC code or Rich markup ``[bold red]`` is shown escaped and literal by the runs
browser, the trend screen, the fleet overview and ``catalog add``; a run dated in the future is flagged in the
runs browser."""

from __future__ import annotations

import asyncio
from pathlib import Path
from typing import Any

from tests.cli import guideway
from tests.tui.sessions import screen_lines
from tests.tui.test_runs_fleet import positioning_runs
from tui.app import GuidewayApp
from tui.screens.fleet import FleetScreen
from tui.screens.trend import TrendScreen

ESC = "\x1b"
MACHINE = f"[bold red]X{ESC}[2J\nforged"  # markup, a clear-screen code and a newline that would forge a row
MACHINE_SHOWN = "[bold red]X\\x1b[2J\\nforged"  # literally, its control characters as escapes


def shown(runs_dir: Path, catalog_url: str | None = None, push: Any = None, size: tuple[int, int] = (160, 48)
          ) -> list[str]:
    """The screen's lines once the runs browser (or the screen ``push(app)`` returns, pushed) has read."""
    out: list[list[str]] = []

    async def main() -> None:
        app = GuidewayApp(runs_dir=runs_dir, start="runs", catalog_url=catalog_url)
        async with app.run_test(size=size) as pilot:
            await pilot.pause()
            if push is not None:
                app.push_screen(push(app))
            for _ in range(100):  # until the catalogue is read ("reading ..." gone)
                await pilot.pause(0.05)
                await app.workers.wait_for_complete()
                await pilot.pause()
                if "reading" not in "\n".join(screen_lines(app)):
                    break
            out.append(screen_lines(app))

    asyncio.run(main())
    return out[0]


def squeezed(lines: list[str]) -> str:
    return " ".join(" ".join(lines).split())


def test_the_runs_browser_shows_a_hostile_machine_and_run_name_literally(tmp_path: Path) -> None:
    positioning_runs(tmp_path, {f"run{ESC}]0;owned\a": MACHINE})
    lines = shown(tmp_path, size=(200, 30))
    text = "\n".join(lines)
    assert ESC not in text and "\a" not in text
    assert MACHINE_SHOWN in squeezed(lines)
    assert "run\\x1b]0;owned\\x07" in text


def test_a_run_dated_in_the_future_is_flagged_in_the_runs_browser(tmp_path: Path) -> None:
    positioning_runs(tmp_path, {"ok": "m1", "ahead": "m1"}, created={"ok": "2026-01-01T00:00:00Z",
                                                                      "ahead": "2099-01-01T00:00:00Z"})
    lines = shown(tmp_path)
    text = "\n".join(lines)
    assert "1 dated in the future" in text
    rows = [ln for ln in lines if " ok " in ln or "ahead" in ln]
    assert any("! ahead" in ln for ln in rows) and not any("! ok" in ln for ln in rows), rows
    # the line under the table says why for the selected (newest: the future) run
    assert "dated in the future (created 2099-01-01T00:00:00Z): check the rig's clock" in text


def catalogued(tmp_path: Path) -> tuple[str, dict[str, Path], str, str]:
    folder = tmp_path / "runs"
    folder.mkdir()
    runs = positioning_runs(folder, {"first": MACHINE, f"second{ESC}[31m": MACHINE})
    url = f"sqlite:///{tmp_path / 'catalog.sqlite'}"
    result = guideway("catalog", "add", "--scan", folder, "--catalog", url)
    assert result.returncode == 0, result.stderr
    return url, runs, result.stdout, result.stderr


def test_catalog_add_prints_the_paths_escaped(tmp_path: Path) -> None:
    _, runs, out, err = catalogued(tmp_path)
    assert ESC not in out + err
    added = [ln for ln in out.splitlines() if ln.startswith("added: ")]
    assert len(added) == 2  # one line each: no name broke a line
    assert any(ln.endswith("second\\x1b[31m") for ln in added), added


def test_the_trend_screen_shows_the_names_literally(tmp_path: Path) -> None:
    url, _, _, _ = catalogued(tmp_path)
    empty = tmp_path / "empty"
    empty.mkdir()
    lines = shown(empty, url, lambda app: TrendScreen(url, MACHINE, "X", "E"))
    text = "\n".join(lines)
    assert ESC not in text
    assert f"machine {MACHINE_SHOWN}" in text
    assert "second\\x1b[31m" in text  # the run's name in the table


def test_the_fleet_screen_shows_the_names_literally(tmp_path: Path) -> None:
    url, _, _, _ = catalogued(tmp_path)
    empty = tmp_path / "empty"
    empty.mkdir()
    lines = shown(empty, url, lambda app: FleetScreen(url), size=(250, 30))
    text = "\n".join(lines)
    assert ESC not in text
    assert "[bold red]X\\x1b[2J\\nforged" in text


def test_the_results_title_shows_the_machine_and_axis_literally(tmp_path: Path) -> None:
    from tests.tui.test_results_screen import copy_run, on_results

    run = copy_run(tmp_path, "positioning-x", machine=MACHINE, axis=f"X{ESC}[5m")

    async def check(app: Any, pilot: Any) -> str:
        await pilot.pause()
        return "\n".join(screen_lines(app))

    text = on_results(run, check, size=(200, 30))
    assert ESC not in text
    assert f"{MACHINE_SHOWN} · axis X\\x1b[5m" in text


def test_literal_text_survives_any_markup_around_it() -> None:
    """Every string of brackets, backslashes, tag-like and control characters reads back as its printable form
    inside markup (Textual's own escape lets ``x [5m`` through, and the tag after it then fails)."""
    import random

    from textual.markup import to_content

    from saved_runs.errors import printable
    from tui.text import literal

    rng = random.Random(25)
    alphabet = "[]\\/@=$ab 1#.:\x1b\n"
    for _ in range(3000):
        t = "".join(rng.choice(alphabet) for _ in range(rng.randint(0, 12)))
        shown = printable(t) + (" " if printable(t).endswith("\\") else "")
        assert to_content(f"[b]{literal(t)}[/b] · [green]ok[/green]").plain == f"{shown} · ok", repr(t)
    assert to_content(f"{literal('[bold red]X')} [b]y[/b]").plain == "[bold red]X y"
