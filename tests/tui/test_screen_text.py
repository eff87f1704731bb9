"""What the screens show, character for character: text from devices, files and the set-up loader
appears as it is (never read as Textual markup), and the run screens describe the run they show."""

from __future__ import annotations

import asyncio
import shutil
from pathlib import Path
from typing import Any

from acquisition.messages import Prompt
from acquisition.setup_file import setup_from_dict
from tests.tui.frozen import RUNS, ifm, straightness_session
from tests.tui.sessions import POSITIONING, screen_lines, screen_name, widget_text
from tests.waiting import wait_for_app
from tui.app import GuidewayApp
from tui.screens.dialogs import QuestionScreen
from tui.screens.run import CaptureScreen, ConnectScreen

ROOT = Path(__file__).resolve().parents[2]


def show_screen(make_screen: Any, *, modal: Any = None, size: tuple[int, int] = (80, 24),
                check: Any = None, runs_dir: Path = ROOT / RUNS) -> Any:
    """Run the app on ``make_screen(app)`` (and a modal on top), then ``check(app)``."""
    out: list[Any] = []

    async def main() -> None:
        app = GuidewayApp(runs_dir=runs_dir, start="runs")
        async with app.run_test(size=size) as pilot:
            screen = make_screen(app)
            app.session = getattr(screen, "session", None)
            app._switch(screen)
            await pilot.pause()
            if modal is not None:
                app.push_screen(modal)
                await pilot.pause()
            out.append(check(app) if check is not None else None)

    asyncio.run(main())
    return out[0]


def test_status_flags_of_the_interferometer_are_shown() -> None:
    # status_flags() writes the set flags in brackets: "status 0x0015 [ready data-valid beam-ok] sequence 41"
    text = show_screen(lambda _a: ConnectScreen(straightness_session("warmup")),
                       check=lambda app: widget_text(app, "#readout"))
    assert "status 0x0015 [ready data-valid beam-ok] sequence 41" in text


def test_device_text_with_brackets_in_a_dialog_is_shown_as_it_is() -> None:
    # a garbage reply quoted in a fault message may hold anything, "[/]" included
    fault = "displacement sensor: garbage reply b'[/]\\x8f[axis]' (expected b'M0,...'); check the protocol setting"
    prompt = Prompt(f"Device fault: {fault}. Retry or abort?", ("retry", "abort"), key="fault", fault=fault)
    text = show_screen(lambda _a: CaptureScreen(straightness_session("capture")), modal=QuestionScreen(prompt),
                       check=lambda app: (screen_name(app), widget_text(app, "#dialog-text")))
    assert text[0] == "QuestionScreen"
    assert "garbage reply b'[/]\\x8f[axis]'" in text[1]


def test_log_lines_and_live_problems_with_brackets_are_shown_as_they_are() -> None:
    from acquisition.monitor import LiveReading

    def screen(_app: Any) -> CaptureScreen:
        s = straightness_session("capture")
        s.view.log.append("note: [sensor] port /dev/ttyUSB0 [/] answered")
        s.view.reading = LiveReading(0.0, sensor_mm=0.01, sensor_status="ok", interferometer=ifm(),
                                     problem="interferometer: reply [1, 2] too short")
        return CaptureScreen(s)

    log, status = show_screen(screen, check=lambda app: (widget_text(app, "#log"), widget_text(app, "#live-status")))
    assert "note: [sensor] port /dev/ttyUSB0 [/] answered" in log
    assert "interferometer: reply [1, 2] too short" in status


def test_a_loader_message_naming_a_table_keeps_its_brackets() -> None:
    axis = {k: v for k, v in POSITIONING["axis"].items() if k != "end_mm"}  # neither end_mm nor targets_mm
    source = {**POSITIONING, "axis": axis}
    try:
        setup_from_dict(source, "set-up")
    except Exception as exc:  # noqa: BLE001 - the loader's own message is the expected text
        expected = str(exc).removeprefix("set-up: ")
    assert expected.startswith("[axis] give end_mm")

    async def main() -> str:
        app = GuidewayApp(setup_source=source, runs_dir=ROOT / RUNS, start="setup")
        async with app.run_test(size=(80, 24)) as pilot:
            await wait_for_app(pilot, lambda: getattr(app.screen, "ready", False), what="the set-up form")
            await pilot.pause()
            return widget_text(app, "#setup-status")

    assert expected in asyncio.run(main())


def test_runs_screen_shows_a_machine_name_with_brackets(tmp_path: Path) -> None:
    run = tmp_path / "runs" / "bed"
    shutil.copytree(ROOT / RUNS / "straightness-bed", run)
    meta = (run / "run.json").read_text().replace('"Machine 7, bed"', '"Mill [a] bed"')
    (run / "run.json").write_text(meta)

    from tui.screens.runs import RunsScreen

    lines = show_screen(lambda _a: RunsScreen(tmp_path / "runs"), size=(160, 24), check=screen_lines)
    assert any("Mill [a] bed" in ln for ln in lines)
