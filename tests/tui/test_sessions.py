"""Complete simulated sessions driven only by key presses through the Textual pilot.

The run directory the TUI writes is compared with what ``guideway acquire --simulate --auto``
writes for the same set-up and seed (no-noise simulation: every measured column equal), and the
results screen with ``guideway process --json`` of the same run.
"""

from __future__ import annotations

import asyncio
import io
import json
from pathlib import Path

import pytest

from acquisition.acquire import SimOptions, acquire
from saved_runs.evaluation.positioning import positioning_deviations
from saved_runs.store.reader import load_run
from tests.tui.sessions import (
    POSITIONING,
    STRAIGHTNESS,
    answer_all,
    assert_same_points,
    press_start,
    process_json,
    screen_name,
    widget_text,
)
from tests.waiting import wait_for_app
from tui.app import GuidewayApp

SIM = SimOptions(seed=3, noise=False)


def auto_run(source: dict, out: Path) -> Path:
    res = acquire(source["kind"], source, "test", out, simulate=SIM, auto=True, stream=io.StringIO())
    assert res.outcome.exit_status == "success"
    return out


def app_for(source: dict, out: Path, **kw) -> GuidewayApp:
    return GuidewayApp(setup_source=source, out=out, runs_dir=out.parent, simulate=True, seed=SIM.seed,
                       noise=SIM.noise, **kw)


def test_straightness_session_with_return_pass_equals_the_automatic_run(tmp_path: Path) -> None:
    out = tmp_path / "tui"

    async def session() -> None:
        app = app_for(STRAIGHTNESS, out)
        async with app.run_test(size=(80, 24)) as pilot:
            await press_start(pilot, app)
            await wait_for_app(pilot, lambda: screen_name(app) == "ConnectScreen", what="connect screen")
            steps = await answer_all(pilot, app)
            # datum placement, stations 1-3 forward, then the return pass 3, 2, 1, 0 (it starts where the
            # forward pass ended: 4 + 4 points, docs/acquisition.md)
            assert steps == 1 + 3 + 4
            await wait_for_app(pilot, lambda: screen_name(app) == "ResultsScreen", what="results")
            await wait_for_app(pilot, lambda: app.screen.evaluation is not None, what="the evaluation")
            await pilot.pause()
            summary = widget_text(app, "#summary")
        expected = process_json(out)
        for name, label in (("endpoint", "end-point"), ("least_squares", "least squares"),
                            ("minimum_zone", "minimum zone")):
            value = expected["straightness_um"][name]
            u = expected["uncertainty_um"]["straightness"][name]
            line = next(ln for ln in summary.splitlines() if ln.startswith(label))
            assert f"{value:.3f} um" in line and f"± {u:.3f} um" in line
        assert f"{expected['return_pass']['closure_um']:.3f} um" in summary

    asyncio.run(session())
    meta = json.loads((out / "run.json").read_text())
    assert meta["status"] == "complete" and meta["warmup"]["stable"] and not meta["warmup"]["overridden"]
    assert_same_points(out, auto_run(STRAIGHTNESS, tmp_path / "auto"))


def test_linear_positioning_session_equals_the_automatic_run(tmp_path: Path) -> None:
    out = tmp_path / "tui"
    shown: dict = {}  # the live deviations on the capture screen when the run ended
    shown_label: list[str] = []

    async def session() -> None:
        app = app_for(POSITIONING, out)
        async with app.run_test(size=(80, 24)) as pilot:
            await press_start(pilot, app)
            await wait_for_app(pilot, lambda: screen_name(app) == "ConnectScreen", what="connect screen")
            assert await answer_all(pilot, app) == 2  # datum, cycle start; the PLC signals every target
            await wait_for_app(pilot, lambda: screen_name(app) == "ResultsScreen", what="results")
            await wait_for_app(pilot, lambda: app.screen.evaluation is not None, what="the evaluation")
            await pilot.pause()
            summary = widget_text(app, "#summary")
            shown.update(app.session.view.deviations)
            shown_label.append(app.session.view.deviation_label)
        iso = process_json(out)["iso230_2"]
        for q, label in (("B", "reversal B"), ("R", "repeatability R "), ("E", "systematic E "),
                         ("M", "mean positional M"), ("A", "accuracy A ")):
            assert any(label in ln and f"{iso[q]:.3f}" in ln.split(label)[1][:30] for ln in summary.splitlines()), q

    asyncio.run(session())
    assert json.loads((out / "run.json").read_text())["status"] == "complete"
    assert_same_points(out, auto_run(POSITIONING, tmp_path / "auto"))
    # the live display showed every point's deviation after environmental compensation, as process computes
    # it for the whole run (the raw reading - target is hundreds of um off in the simulated air)
    processed, _, _ = positioning_deviations(load_run(out))
    assert shown_label == ["environment-compensated"] and len(shown) == len(processed) > 0
    for row in processed.itertuples():
        target, dev = shown[(int(row.run), int(row.direction), int(row.target_index))]
        assert target == pytest.approx(row.target) and dev == pytest.approx(row.deviation, abs=1e-6)


@pytest.mark.parametrize("faults", ["sensor:drop@5x1", "controller:exception@15x1"])
def test_device_fault_shows_the_dialog_and_retry_loses_no_point(tmp_path: Path, faults: str) -> None:
    out = tmp_path / "tui"
    source = {**STRAIGHTNESS, "block": {**STRAIGHTNESS["block"], "return_pass": False},
              "warmup": {"enabled": False}}
    seen: list[str] = []

    async def session() -> None:
        # live readings off (hour-long interval): the injected fault must meet the engine, not the monitor
        app = app_for(source, out, faults=faults, live_interval_s=3600.0)
        async with app.run_test(size=(80, 24)) as pilot:
            await press_start(pilot, app)
            await wait_for_app(pilot, lambda: app.session is not None, what="the session")
            session = app.session
            while True:
                await wait_for_app(pilot, lambda: session.view.question is not None or not session.active,
                                   what="a question")
                q = session.view.question
                if q is None:
                    break
                if getattr(q, "key", "") == "fault":
                    await wait_for_app(pilot, lambda: screen_name(app) == "QuestionScreen"
                                       and bool(app.screen.query("#dialog-title")), what="the fault dialog")
                    seen.append(widget_text(app, "#dialog-title") + ": " + widget_text(app, "#dialog-text"))
                    assert app.screen.query_one("#dialog").has_class("fault")  # drawn as a fault
                    await pilot.press("r")  # retry
                elif screen_name(app) == "QuestionScreen":
                    await pilot.press("enter")
                else:
                    await pilot.press("space")
                await wait_for_app(pilot, lambda q=q: session.view.question is not q, what="the answer")
            await wait_for_app(pilot, lambda: screen_name(app) == "ResultsScreen", what="results")

    asyncio.run(session())
    # the dialog says in plain words which device failed and how, with the attempt count in its title; the
    # driver's line (b'\r', exception names, register numbers) is one key away, not on the first line
    device = "The displacement sensor" if faults.startswith("sensor") else "The interferometer controller"
    assert len(seen) == 1 and seen[0].startswith("Device fault · attempt 1 · failing for "), seen
    first_line = seen[0].split(": ", 1)[1].splitlines()[0]
    assert first_line.startswith(device), seen
    assert not any(tech in first_line for tech in ("b'", "errno", "Errno", "register", "0x", "(", "modbus")), seen
    meta = json.loads((out / "run.json").read_text())
    assert meta["status"] == "complete" and len(meta["faults"]) == 1
    rows = (out / "points.csv").read_text().splitlines()[1:]
    assert [int(r.split(",")[0]) for r in rows] == [0, 1, 2, 3]  # every station, none lost or doubled


def test_quit_mid_run_then_resume_from_the_runs_screen_completes_the_run(tmp_path: Path) -> None:
    out = tmp_path / "runs" / "r1"
    source = {**STRAIGHTNESS, "warmup": {"enabled": False}}

    async def first() -> None:
        app = app_for(source, out)
        async with app.run_test(size=(80, 24)) as pilot:
            await press_start(pilot, app)
            await wait_for_app(pilot, lambda: app.session is not None, what="the session")
            await answer_all(pilot, app, stop_after=3)  # datum, stations 1 and 2
            await wait_for_app(pilot, lambda: app.session.view.points == 3, what="three points on disk")
            await pilot.press("q")
            await wait_for_app(pilot, lambda: screen_name(app) == "ConfirmScreen", what="quit question")
            await pilot.press("y")
            await wait_for_app(pilot, lambda: not app.session.active, what="the run to end")

    asyncio.run(first())
    meta = json.loads((out / "run.json").read_text())
    assert meta["status"] == "aborted" and meta["points"] == 3

    async def second() -> None:
        app = GuidewayApp(runs_dir=out.parent, start="runs", simulate=True, noise=False, seed=SIM.seed)
        async with app.run_test(size=(80, 24)) as pilot:
            await pilot.pause()
            assert "aborted" in str(app.screen.query_one("#runs-table").get_row_at(0))
            await pilot.press("c")
            await wait_for_app(pilot, lambda: app.session is not None, what="the resumed session")
            await wait_for_app(pilot, lambda: app.session.view.question is not None, what="the resume question")
            assert app.session.view.question.key == "resume"
            await pilot.press("enter")  # continue
            await wait_for_app(pilot, lambda: screen_name(app) == "CaptureScreen"
                               and app.session.view.question is not None
                               and app.session.view.question.key == "station", what="the capture screen")
            assert app.session.view.question.params == {"station": 3, "pass": 0}  # after the last point on disk
            await answer_all(pilot, app)
            await wait_for_app(pilot, lambda: screen_name(app) == "ResultsScreen", what="results")

    asyncio.run(second())
    meta = json.loads((out / "run.json").read_text())
    assert meta["status"] == "complete" and meta["points"] == 8  # 4 forward + 4 return
    assert_same_points(out, auto_run(source, tmp_path / "auto"))


ROTARY_MANUAL = {
    "kind": "positioning", "machine": "test bench", "operator": "pilot",
    # datum 10 deg (the start): the axis angle is the datum plus the angle the controller reports from it
    "axis": {"name": "C", "type": "rotary", "start_deg": 10.0, "end_deg": 370.0, "runs": 1},
    "trigger": {"mode": "manual", "dwell_s": 0.0},
}


def test_rotary_capture_screen_shows_the_live_axis_angle(tmp_path: Path) -> None:
    out = tmp_path / "tui"
    shown: list[tuple[str, float]] = []  # (Digits text once it showed the axis at rest, the angle recorded there)

    async def session() -> None:
        app = app_for(ROTARY_MANUAL, out)
        async with app.run_test(size=(80, 24)) as pilot:
            await press_start(pilot, app)
            await wait_for_app(pilot, lambda: screen_name(app) == "ConnectScreen", what="connect screen")
            await answer_all(pilot, app, stop_after=1)  # the datum
            s = app.session
            for _ in range(3):  # manual trigger: the axis rests at the target captured last (M00) until Space
                await wait_for_app(pilot, lambda: screen_name(app) == "CaptureScreen" and s.view.question is not None,
                                   what="the next target")
                q = s.view.question
                if s.view.last_point is not None:
                    # the raw axis angle, small beside the big deviation (the axis is not at the next target
                    # yet: no deviation, "-.--")
                    expected = f"raw {s.view.last_point['reading_deg']:+.5f} deg = datum 10 + angle"
                    await wait_for_app(pilot, lambda e=expected: e in widget_text(app, "#live-status"),
                                       what=f"the live angle {expected}")
                    shown.append((expected, s.view.last_point["reading_deg"]))
                    assert str(app.screen.query_one("#live").value) == "-.--"
                await pilot.press("space")
                await wait_for_app(pilot, lambda q=q: s.view.question is not q, what="the capture")
            await pilot.press("q")
            await wait_for_app(pilot, lambda: screen_name(app) == "ConfirmScreen", what="quit question")
            await pilot.press("y")
            await wait_for_app(pilot, lambda: not app.session.active, what="the run to end")

    asyncio.run(session())
    assert len(shown) == 2
    # the points on disk: the angles the screen showed are the plan's recorded readings (axis frame, near the targets)
    rows = (out / "points.csv").read_text().splitlines()
    header = rows[0].split(",")
    recorded = [float(r.split(",")[header.index("reading_deg")]) for r in rows[1:]]
    targets = [float(r.split(",")[header.index("target_deg")]) for r in rows[1:]]
    assert [v for _, v in shown] == recorded[:2]
    assert all(abs(r - t) < 20 / 3600 for r, t in zip(recorded, targets, strict=True)) and targets[1] > 10.0


def test_app_closed_mid_run_shuts_down_cleanly_and_leaves_the_run_resumable(tmp_path: Path) -> None:
    # ctrl+q (Textual's own quit) or a closed terminal: no quit question; the live readings still arrive
    # while the screens are taken down
    out = tmp_path / "tui"
    source = {**STRAIGHTNESS, "warmup": {"enabled": False}}

    async def session() -> None:
        app = app_for(source, out, live_interval_s=0.01)
        async with app.run_test(size=(80, 24)) as pilot:
            await press_start(pilot, app)
            await wait_for_app(pilot, lambda: app.session is not None, what="the session")
            await answer_all(pilot, app, stop_after=2)  # datum, station 1
            s = app.session
            await wait_for_app(pilot, lambda: s.view.points == 2 and s.view.question is not None, what="two points")
            seen = s.view.reading
            await wait_for_app(pilot, lambda: s.view.reading is not seen, what="live readings")
            app.exit()

    asyncio.run(session())  # (run_test re-raises an exception of the app)
    meta = json.loads((out / "run.json").read_text())
    assert meta["status"] == "aborted" and meta["points"] == 2


def test_o_overrides_the_warm_up_and_the_run_records_it(tmp_path: Path) -> None:
    out = tmp_path / "tui"
    # a window of 1000 readings: the warm-up cannot become stable by itself within the test
    source = {**STRAIGHTNESS, "block": {**STRAIGHTNESS["block"], "stations": 2, "return_pass": False},
              "warmup": {"enabled": True, "window": 1000, "interval_s": 0.05}}

    async def session() -> None:
        app = app_for(source, out)
        async with app.run_test(size=(80, 24)) as pilot:
            await press_start(pilot, app)
            await wait_for_app(pilot, lambda: screen_name(app) == "ConnectScreen", what="connect screen")
            s = app.session
            await wait_for_app(pilot, lambda: s.view.question is not None, what="the datum instruction")
            await pilot.press("space")  # the block is at the datum; the warm-up starts
            await wait_for_app(pilot, lambda: s.view.warmup.get("state") == "drifting", what="the warm-up")
            assert "DRIFTING" in widget_text(app, "#state")
            await pilot.press("o")
            await wait_for_app(pilot, lambda: s.view.warmup.get("state") == "overridden", what="the override")
            await answer_all(pilot, app)
            await wait_for_app(pilot, lambda: screen_name(app) == "ResultsScreen", what="results")

    asyncio.run(session())
    meta = json.loads((out / "run.json").read_text())
    assert meta["status"] == "complete" and meta["warmup"]["overridden"] and not meta["warmup"]["stable"]
