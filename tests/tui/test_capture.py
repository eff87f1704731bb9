"""The capture screen a technician acts on (issue 17, Capture and Faults): the big number, station k of N,
the stability light and auto-capture, confirmations, keys pressed while busy, the warm-up box, the fault
dialog and the wide layout."""

from __future__ import annotations

import asyncio
import json
from pathlib import Path
from typing import Any

import pandas as pd
import pytest

from acquisition.messages import Instruct
from acquisition.monitor import LiveReading
from acquisition.plans.straightness import point_record
from acquisition.setup.files import setup_from_dict
from drivers.readings import AveragedDisplacement
from processing.decoupling import decouple
from tests.tui.frozen import FAULT, FAULT_TEXT, RUNS, ifm, straightness_session
from tests.tui.sessions import POSITIONING, STRAIGHTNESS, press_start, screen_name, widget_text
from tests.tui.test_screen_text import show_screen
from tests.waiting import wait_for_app
from tui.app import GuidewayApp, plan_info
from tui.messages import LiveReadingArrived, OperatorQuestion, RunDocument
from tui.screens.run import CaptureScreen, ConnectScreen
from tui.session import RunSession

QUICK = {**STRAIGHTNESS, "block": {**STRAIGHTNESS["block"], "return_pass": False}, "warmup": {"enabled": False}}


def station_instruction(k: int, pass_: int = 0) -> Instruct:
    return Instruct("place_block", f"Move the block to station {k}.", {"station": k, "pass": pass_},
                    choices=("capture", "redo", "skip", "pause", "abort"), key="station")


def session_of(source: dict[str, Any]) -> RunSession:
    setup = setup_from_dict(source)
    s = RunSession(lambda _m: None, plan_info(setup), source, RUNS / "new", simulate=None)
    s.view.started, s.view.state = True, "running"
    return s


# -- what the screen says -------------------------------------------------------------------------------------

@pytest.mark.parametrize(("station", "ordinal"), [(1, 2), (19, 20)])
def test_the_station_count_is_the_set_ups_station_count(station: int, ordinal: int) -> None:
    s = session_of({**QUICK, "block": {**QUICK["block"], "stations": 20}})
    s.apply(OperatorQuestion(station_instruction(station), 1))
    step = show_screen(lambda _a: CaptureScreen(s), check=lambda app: widget_text(app, "#step"))
    # 20 stations numbered 0 (the datum) to 19: station 1 is the 2nd of 20, station 19 the 20th of 20
    assert f"Station {station} (x = {station * 100:g} mm) · {ordinal} of 20 stations" in step


def captured_rows(s: RunSession, n: int) -> list[dict[str, Any]]:
    """``n`` points as the plan records them, applied to the session; the readings tilt a little per station."""
    rows = []
    for k in range(n):
        r = ifm(position_mm=100.0 * k, stry_um=0.8 * k)
        sensor = AveragedDisplacement(0.010 + 0.002 * k, 0.0, 2, 0, 0.0)
        rows.append(point_record(k, 100.0 * k, 0.0, r, sensor))
        s.apply(RunDocument("event", {"data": rows[-1]}))
    return rows


def test_the_big_number_is_the_live_surface_height_decoupled_as_process_does() -> None:
    s = session_of(QUICK)
    rows = captured_rows(s, 3)
    s.apply(OperatorQuestion(station_instruction(3), 1))
    live = ifm(position_mm=300.004, stry_um=2.9)
    s.apply(LiveReadingArrived(LiveReading(1.0, sensor_mm=0.0161, sensor_status="ok", sensor_mean_mm=0.0161,
                                           sensor_count=1, interferometer=live)))
    # the height `guideway process` would give this reading captured at station 3, from processing itself
    live_row = point_record(3, 300.0, 0.0, live, AveragedDisplacement(0.0161, 0.0, 1, 0, 0.0))
    expected = decouple(pd.DataFrame([*rows, live_row]), setup_from_dict(QUICK).geometry)["height_um"].iloc[-1]
    digits = show_screen(lambda _a: CaptureScreen(s), check=lambda app: app.screen.query_one("#live").value)
    assert s.view.live_value == pytest.approx(expected, abs=1e-9)
    assert digits == f"{expected:+.2f}"
    # the block 4 um past the station, shown with the station's verdict
    text = show_screen(lambda _a: CaptureScreen(s), check=lambda app: widget_text(app, "#live-status"))
    assert "+4.0 um, at the station" in text and "sensor +0.01610 mm" in text


def test_no_height_is_shown_while_the_block_is_not_at_the_station() -> None:
    s = session_of(QUICK)
    captured_rows(s, 2)
    s.apply(OperatorQuestion(station_instruction(2), 1))
    s.apply(LiveReadingArrived(LiveReading(1.0, sensor_mm=0.01, sensor_status="ok", sensor_mean_mm=0.01,
                                           sensor_count=1, interferometer=ifm(position_mm=100.0))))
    texts = show_screen(lambda _a: CaptureScreen(s), check=lambda app: (app.screen.query_one("#live").value,
                                                                        widget_text(app, "#live-caption"),
                                                                        widget_text(app, "#live-status")))
    assert texts[0] == "-.--" and "not at station 2" in texts[1]
    assert "100.000 mm to the station" in texts[2]


def test_positioning_shows_the_compensated_deviation_the_target_and_the_distance_to_it() -> None:
    # readings the controller compensated: the deviation is the reading minus the target, in um
    source = {**POSITIONING, "environment": {"readings_compensated": True}}
    s = session_of(source)
    stops = setup_from_dict(source).measured_stops()
    for stop in stops[:3]:
        s.apply(RunDocument("event", {"data": {"run": stop.run, "direction": stop.direction,
                                               "target_index": stop.target_index, "target_mm": stop.position,
                                               "reading_mm": stop.position, "air_temp_c": 20.0}}))
    target = stops[3]
    position = target.position + 0.0123  # 12.3 um beyond the 4th stop
    s.apply(LiveReadingArrived(LiveReading(1.0, interferometer=ifm(position_mm=position))))
    texts = show_screen(lambda _a: CaptureScreen(s), check=lambda app: (
        app.screen.query_one("#live").value, widget_text(app, "#live-caption"), widget_text(app, "#step"),
        widget_text(app, "#live-status")))
    assert texts[0] == "+12.30" and "deviation um, ctrl-comp." in texts[1]
    runs = POSITIONING["axis"]["runs"]
    arrow = "up (+)" if target.direction > 0 else "down (-)"
    m = len(setup_from_dict(source).targets)
    assert texts[2] == f"Target {target.target_index} of {m} · run {target.run} of {runs} · {arrow}"
    assert f"target {target.position:g} mm · axis +0.0123 mm from it" in texts[3]


def test_beam_and_signal_state_are_in_words() -> None:
    s = straightness_session("capture")
    text = show_screen(lambda _a: CaptureScreen(s), check=lambda app: widget_text(app, "#live-status"))
    assert "beam OK · data valid · sensor ok" in text


def test_the_warm_up_box_says_what_it_waits_for_and_the_override_key() -> None:
    s = straightness_session("warmup")
    s.view.question = None  # the datum confirmed: the warm-up runs
    text = show_screen(lambda _a: ConnectScreen(s), check=lambda app: widget_text(app, "#instruction"))
    assert "drift (peak to peak over the last 5 readings) is below 0.5 um (interferometer" in text
    assert "0.5 um (sensor); now 0.31 / 0.72 um" in text
    assert "o override now" in text


def test_the_state_line_is_not_connected_behind_a_fault_dialog() -> None:
    from tui.screens.dialogs import FaultScreen

    s = straightness_session("warmup")
    s.view.warmup = {}
    s.view.question = None
    s.apply(RunDocument("state", {"state": "paused", "reason": FAULT_TEXT}))
    s.apply(OperatorQuestion(FAULT, 2))
    state = show_screen(lambda _a: ConnectScreen(s), modal=FaultScreen(FAULT),
                        check=lambda app: str(app.screen_stack[-2].query_one("#state").render()))
    assert "CONNECTED" not in state and "DEVICE FAULT" in state
    s.apply(RunDocument("state", {"state": "running", "reason": "device fault cleared"}))
    state = show_screen(lambda _a: ConnectScreen(s), check=lambda app: widget_text(app, "#state"))
    assert "DEVICE FAULT" not in state and "PAUSED" not in state


# -- the fault dialog ---------------------------------------------------------------------------------------------

def test_the_fault_dialog_counts_the_attempts_and_shows_the_technical_line_on_d() -> None:
    from tui.screens.dialogs import FaultScreen

    s = straightness_session("capture")
    s.apply(RunDocument("state", {"state": "paused", "reason": FAULT_TEXT}))
    for ticket in (2, 3, 4):  # the first failure, then two retries that failed again
        s.apply(OperatorQuestion(FAULT, ticket))
    assert s.view.fault_attempts == 3

    async def main() -> tuple[str, str, bool, str, bool]:
        app = GuidewayApp(runs_dir=RUNS, start="runs")
        async with app.run_test(size=(80, 24)) as pilot:
            app.session = s
            app._switch(CaptureScreen(s))
            await pilot.pause()
            app.push_screen(FaultScreen(FAULT, s.view.fault_attempts, since=100.0, clock=lambda: 175.0))
            await pilot.pause()
            title, text = widget_text(app, "#dialog-title"), widget_text(app, "#dialog-text")
            hidden = app.screen.query_one("#fault-detail").display
            await pilot.press("d")
            await pilot.pause()
            return title, text, hidden, widget_text(app, "#fault-detail"), app.screen.query_one("#fault-detail").display

    title, text, shown_before, detail, shown_after = asyncio.run(main())
    assert title == "Device fault · attempt 3 · failing for 1 min 15 s"
    first = text.splitlines()[0]
    assert first == "The displacement sensor did not answer in time."
    assert "b'" not in text and "keyence" not in text
    assert not shown_before and shown_after and "no reply ending in b'\\r'" in detail


# -- keys -------------------------------------------------------------------------------------------------------

@pytest.mark.parametrize(("key", "choice"), [("s", "skip"), ("r", "redo")])
def test_redo_and_skip_ask_first(key: str, choice: str) -> None:
    s = straightness_session("capture")

    async def main() -> tuple[str, Any, Any]:
        app = GuidewayApp(runs_dir=RUNS, start="runs")
        async with app.run_test(size=(80, 24)) as pilot:
            app.session = s
            app._switch(CaptureScreen(s))
            await pilot.pause()
            await pilot.press(key)
            await pilot.pause()
            asked = screen_name(app)
            await pilot.press("n")  # no: nothing is answered
            await pilot.pause()
            after_no = s.view.question
            await pilot.press(key, "y")
            await pilot.pause()
            return asked, after_no, s.operator._answers.get_nowait()

    asked, after_no, answer = asyncio.run(main())
    assert asked == "ConfirmScreen" and isinstance(after_no, Instruct)
    assert answer == (s.view.ticket, choice)


def run_app(source: dict[str, Any], out: Path, **kw: Any) -> GuidewayApp:
    return GuidewayApp(setup_source=source, out=out, runs_dir=out.parent, simulate=True, seed=3, noise=False, **kw)


async def at_station(pilot: Any, app: Any, k: int) -> RunSession:
    """Start the run and confirm the datum; return when station ``k`` is asked for."""
    await press_start(pilot, app)
    await wait_for_app(pilot, lambda: app.session is not None and app.session.view.question is not None,
                       what="the datum instruction")
    session = app.session
    await pilot.press("space")
    await wait_for_app(pilot, lambda: isinstance(session.view.question, Instruct)
                       and session.view.question.params.get("station") == k and screen_name(app) == "CaptureScreen",
                       what=f"station {k}")
    return session


def test_the_pause_dialog_resumes_with_p_not_r_and_paused_goes_away_after(tmp_path: Path) -> None:
    async def main() -> tuple[list[str], str, str, str]:
        app = run_app(QUICK, tmp_path / "run")
        async with app.run_test(size=(80, 24)) as pilot:
            session = await at_station(pilot, app, 1)
            await pilot.press("p")
            await wait_for_app(pilot, lambda: screen_name(app) == "QuestionScreen", what="the pause dialog")
            keys = list(app.screen.keys)
            await pilot.press("r")  # redo underneath: the dialog does not take it as resume
            await pilot.pause(0.3)
            still = screen_name(app)
            await pilot.press("p")
            await wait_for_app(pilot, lambda: screen_name(app) == "CaptureScreen" and session.view.state == "running"
                               and isinstance(session.view.question, Instruct), what="the run again")
            await pilot.pause(0.2)
            text = widget_text(app, "#instruction") + widget_text(app, "#step")
            await pilot.press("q", "y")
            return keys, still, text, "\n".join(session.view.log)

    keys, still, text, log = asyncio.run(main())
    assert keys == ["p", "a"] and still == "QuestionScreen"
    assert "paused" not in text.lower()
    assert "running again (resumed)" in log


def test_two_capture_presses_at_the_same_instant_are_never_lost_silently() -> None:
    s = straightness_session("capture")  # no worker: the run stays busy after the first capture
    s.apply(OperatorQuestion(s.view.question, 1))

    async def main() -> tuple[list[Any], list[str], str]:
        app = GuidewayApp(runs_dir=RUNS, start="runs")
        async with app.run_test(size=(80, 24)) as pilot:
            app.session = s
            app._switch(CaptureScreen(s))
            await pilot.pause()
            await pilot.press("space", "space")
            await pilot.pause()
            answers = []
            while not s.operator._answers.empty():
                answers.append(s.operator._answers.get_nowait())
            return answers, [n.message for n in app._notifications], widget_text(app, "#instruction")

    answers, messages, instruction = asyncio.run(main())
    # the first press captures; the second, while that capture runs, is refused with a message on the screen
    assert answers == [(s.view.ticket, "capture")]
    refusal = "'capture' not taken: busy (capturing station 3); press it again when the screen asks"
    assert refusal in messages and refusal in instruction


def test_auto_capture_captures_each_station_once_the_light_is_stable(tmp_path: Path) -> None:
    source = {**QUICK, "auto": {"still_s": 0.6, "still_um": 2.0, "poll_s": 0.25}}
    out = tmp_path / "run"

    async def main() -> set[str]:
        app = run_app(source, out)
        seen: set[str] = set()
        async with app.run_test(size=(80, 24)) as pilot:
            session = await at_station(pilot, app, 1)
            update = session.update_live

            def spy() -> None:  # every state the light shows, the last before each auto-capture included
                update()
                seen.add(session.view.stability)

            session.update_live = spy  # type: ignore[method-assign]
            await pilot.press("t")  # auto-capture on: no more keys
            await wait_for_app(pilot, lambda: not session.active, what="the end of the run")
            await wait_for_app(pilot, lambda: screen_name(app) == "ResultsScreen"
                               and getattr(app.screen, "evaluation", None) is not None, what="the results")
        return seen

    seen = asyncio.run(main())
    meta = json.loads((out / "run.json").read_text())
    assert meta["status"] == "complete" and not meta.get("skipped")
    assert len((out / "points.csv").read_text().splitlines()) == 1 + QUICK["block"]["stations"]
    assert {"settling", "stable"} <= seen


# -- sizes ------------------------------------------------------------------------------------------------------

def regions(app: Any) -> dict[str, Any]:
    return {sel: app.screen.query_one(sel).region for sel in ("#readings", "#plot", "#live-status", "#log")}


def test_at_160x48_the_readings_stand_beside_a_larger_plot() -> None:
    def make(_a: Any) -> CaptureScreen:
        return CaptureScreen(straightness_session("capture"))

    small = show_screen(make, size=(80, 24), check=regions)
    wide = show_screen(make, size=(160, 48), check=regions)
    # 80x24: stacked, every part on the screen
    assert small["#plot"].y >= small["#readings"].bottom and small["#log"].bottom <= 24 - 1
    assert small["#live-status"].right <= 80
    # 160x48: side by side, the plot wider and taller than at 80x24
    assert wide["#plot"].x >= wide["#readings"].right and wide["#plot"].y == wide["#readings"].y
    assert wide["#plot"].height > 2 * small["#plot"].height and wide["#plot"].width > small["#plot"].width
