"""Snapshot tests (pytest-textual-snapshot) of every screen at 80x24 and 160x48.

The screens show fixed states (tests/tui/frozen.py, saved runs under tests/data/tui-runs), so
the SVGs do not depend on the clock, a run uid or a temporary path.  Update only after looking
at the report: ``pytest tests/tui/test_snapshots.py --snapshot-update``.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.tui.frozen import FAULT, JUMP, ROOT, RUNS, positioning_session, rotary_session, straightness_session
from tests.tui.sessions import POSITIONING, STRAIGHTNESS
from tests.waiting import wait_for_app
from tui.app import GuidewayApp
from tui.screens.dialogs import FaultScreen, HelpScreen, QuestionScreen
from tui.screens.run import CaptureScreen, ConnectScreen

SIZES = [(80, 24), (160, 48)]


@pytest.fixture(autouse=True)
def _in_repository(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(ROOT)


def app(**kw) -> GuidewayApp:
    """The app, starting on the (light) Runs screen unless told otherwise; run_before shows the screen under test."""
    return GuidewayApp(runs_dir=RUNS, **{"start": "runs", **kw})


def show(make_screen, modal=None):  # noqa: ANN001, ANN201
    async def run_before(pilot) -> None:  # noqa: ANN001
        screen = make_screen(pilot.app)
        pilot.app.session = getattr(screen, "session", None)
        pilot.app._switch(screen)
        await pilot.pause()
        if modal is not None:
            pilot.app.push_screen(modal(pilot.app))
        await pilot.pause()

    return run_before


async def setup_ready(pilot) -> None:  # noqa: ANN001
    """The set-up form is built after the first frame: snapshot it once it is there and checked."""
    await wait_for_app(pilot, lambda: getattr(pilot.app.screen, "ready", False), what="the set-up form")
    await pilot.pause()


def results(run: str):  # noqa: ANN201
    async def run_before(pilot) -> None:  # noqa: ANN001
        pilot.app.open_results(RUNS / run)
        await wait_for_app(pilot, lambda: getattr(pilot.app.screen, "evaluation", None) is not None,
                           what="the evaluation")
        await pilot.pause()

    return run_before


@pytest.mark.parametrize("size", SIZES)
def test_setup_straightness(snap_compare, size) -> None:  # noqa: ANN001
    assert snap_compare(app(setup_source=STRAIGHTNESS, simulate=True, start="setup"), terminal_size=size,
                        run_before=setup_ready)


@pytest.mark.parametrize("size", SIZES)
def test_setup_positioning_with_a_wrong_field(snap_compare, size) -> None:  # noqa: ANN001
    source = {**POSITIONING, "axis": {**POSITIONING["axis"], "runs": 0}}
    setup = app(setup_source=source, setup_path=Path("docs/setup-positioning.toml"), start="setup")
    assert snap_compare(setup, terminal_size=size, run_before=setup_ready)


@pytest.mark.parametrize("size", SIZES)
def test_connect_and_warmup(snap_compare, size) -> None:  # noqa: ANN001
    assert snap_compare(app(), terminal_size=size,
                        run_before=show(lambda _a: ConnectScreen(straightness_session("warmup"))))


@pytest.mark.parametrize("size", SIZES)
def test_capture_straightness(snap_compare, size) -> None:  # noqa: ANN001
    assert snap_compare(app(), terminal_size=size,
                        run_before=show(lambda _a: CaptureScreen(straightness_session("capture"))))


@pytest.mark.parametrize("size", SIZES)
def test_capture_positioning(snap_compare, size) -> None:  # noqa: ANN001
    assert snap_compare(app(), terminal_size=size, run_before=show(lambda _a: CaptureScreen(positioning_session())))


@pytest.mark.parametrize("size", SIZES)
def test_capture_rotary(snap_compare, size) -> None:  # noqa: ANN001
    assert snap_compare(app(), terminal_size=size, run_before=show(lambda _a: CaptureScreen(rotary_session())))


@pytest.mark.parametrize("size", SIZES)
def test_question_dialog(snap_compare, size) -> None:  # noqa: ANN001
    assert snap_compare(app(), terminal_size=size,
                        run_before=show(lambda _a: CaptureScreen(straightness_session("capture")),
                                        lambda _a: QuestionScreen(JUMP)))


@pytest.mark.parametrize("size", SIZES)
def test_fault_dialog(snap_compare, size) -> None:  # noqa: ANN001
    assert snap_compare(app(), terminal_size=size,
                        run_before=show(lambda _a: CaptureScreen(straightness_session("capture")),
                                        # the second failure in a row, 75 s after the first
                                        lambda _a: FaultScreen(FAULT, 2, since=0.0, clock=lambda: 75.0)))


@pytest.mark.parametrize("size", SIZES)
def test_capture_while_busy(snap_compare, size) -> None:  # noqa: ANN001
    """A capture running (no instruction): a second capture key is refused with the reason on screen."""

    async def run_before(pilot) -> None:  # noqa: ANN001
        await show(lambda _a: CaptureScreen(straightness_session("capture")))(pilot)
        await pilot.press("space", "space")
        await pilot.pause()
        pilot.app.clear_notifications()
        await pilot.pause()

    assert snap_compare(app(), terminal_size=size, run_before=run_before)


@pytest.mark.parametrize("size", SIZES)
def test_help_of_the_capture_screen(snap_compare, size) -> None:  # noqa: ANN001
    assert snap_compare(app(), terminal_size=size,
                        run_before=show(lambda _a: CaptureScreen(straightness_session("capture")),
                                        lambda a: HelpScreen(a.screen, list(a.BINDINGS))))


@pytest.mark.parametrize("size", SIZES)
def test_results_straightness(snap_compare, size) -> None:  # noqa: ANN001
    assert snap_compare(app(), terminal_size=size, run_before=results("straightness-bed"))


@pytest.mark.parametrize("size", SIZES)
def test_results_positioning(snap_compare, size) -> None:  # noqa: ANN001
    assert snap_compare(app(), terminal_size=size, run_before=results("positioning-x"))


@pytest.mark.parametrize("size", SIZES)
def test_diagnosis(snap_compare, size) -> None:  # noqa: ANN001
    async def run_before(pilot) -> None:  # noqa: ANN001
        await results("positioning-x")(pilot)
        await pilot.press("d")  # against docs/model-positioning.toml, the default of a positioning run
        await wait_for_app(pilot, lambda: getattr(pilot.app.screen, "result", None) is not None,
                           what="the diagnosis", timeout_s=60)
        await pilot.pause()

    assert snap_compare(app(), terminal_size=size, run_before=run_before)


@pytest.mark.parametrize("size", SIZES)
def test_runs(snap_compare, size) -> None:  # noqa: ANN001
    assert snap_compare(app(), terminal_size=size)
