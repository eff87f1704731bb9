"""?/F1 help from every screen (issue 25): F1 opens the keys of the screen on top wherever the focus is (a text
field, a yes/no dialog included), ``?`` wherever it is not typed into a text field, and each help says ``?/F1``."""

from __future__ import annotations

import asyncio
from pathlib import Path
from typing import Any

import pytest
from textual.widgets import Input

from tests.tui.frozen import straightness_session
from tests.tui.sessions import screen_lines, screen_name
from tests.waiting import wait_for_app
from tui.app import GuidewayApp
from tui.screens.dialogs import ConfirmScreen
from tui.screens.run import CaptureScreen

ROOT = Path(__file__).resolve().parents[2]
RUNS = ROOT / "tests/data/tui-runs"


async def open_screen(pilot: Any, app: Any, where: str) -> None:
    if where == "results":
        app.open_results(RUNS / "positioning-x")
        await wait_for_app(pilot, lambda: screen_name(app) == "ResultsScreen" and app.screen.is_mounted,
                           what="results", timeout_s=20)
    elif where in ("diagnosis", "diagnosis-field"):
        app.open_results(RUNS / "positioning-x")
        await wait_for_app(pilot, lambda: screen_name(app) == "ResultsScreen", what="results", timeout_s=20)
        await pilot.pause(0.5)
        await pilot.press("d")
        await wait_for_app(pilot, lambda: screen_name(app) == "DiagnosisScreen", what="diagnosis", timeout_s=20)
        if where == "diagnosis-field":
            app.screen.query_one("#model-path", Input).focus()
    elif where == "capture":
        s = straightness_session("capture")
        app.session = s
        app._switch(CaptureScreen(s))
        await wait_for_app(pilot, lambda: screen_name(app) == "CaptureScreen", what="capture")
    elif where == "confirm":
        app.push_screen(ConfirmScreen("Quit?", "really"))
        await wait_for_app(pilot, lambda: screen_name(app) == "ConfirmScreen", what="the dialog")
    await pilot.pause()


def help_with(where: str, key: str) -> tuple[str, str, str]:
    """(the screen under the help, the help's text, the screen after closing it)."""
    out: list[Any] = []

    async def main() -> None:
        app = GuidewayApp(runs_dir=RUNS, start="runs")
        async with app.run_test(size=(100, 30)) as pilot:
            await pilot.pause()
            await open_screen(pilot, app, where)
            under = screen_name(app)
            await pilot.press(key)
            await wait_for_app(pilot, lambda: screen_name(app) == "HelpScreen", what="help", timeout_s=5)
            text = "\n".join(screen_lines(app))
            await pilot.press("escape")
            await pilot.pause()
            out.append((under, text, screen_name(app)))

    asyncio.run(main())
    return out[0]


@pytest.mark.parametrize("key", ["f1", "question_mark"])
@pytest.mark.parametrize("where", ["runs", "results", "diagnosis", "capture"])
def test_f1_and_question_mark_open_help_on_every_screen_and_say_so(where: str, key: str) -> None:
    under, text, after = help_with(where, key)
    assert f"Keys: {under.removesuffix('Screen')}" in text or "Keys:" in text
    assert "?/F1" in text and "help" in text
    assert after == under


def test_f1_opens_help_from_a_text_field_and_a_dialog() -> None:
    under, text, _ = help_with("diagnosis-field", "f1")
    assert under == "DiagnosisScreen" and "?/F1" in text
    under, text, after = help_with("confirm", "f1")
    assert under == "ConfirmScreen" and "yes" in text and f"{'F1':<12} help" in text and after == "ConfirmScreen"
    assert f"{'q':<12} quit" not in text  # q does not quit from under a dialog: not listed there


def test_question_mark_is_typed_in_a_text_field_of_another_screen() -> None:
    async def main() -> tuple[str, str]:
        app = GuidewayApp(runs_dir=RUNS, start="runs")
        async with app.run_test(size=(100, 30)) as pilot:
            await open_screen(pilot, app, "diagnosis-field")
            field = app.screen.query_one("#model-path", Input)
            field.value = ""
            await pilot.press("question_mark")
            await pilot.pause()
            return screen_name(app), field.value

    name, value = asyncio.run(main())
    assert name == "DiagnosisScreen" and value == "?"
