"""What the screens show, character for character: text from devices, files and the set-up loader
appears as it is (never read as Textual markup), and the run screens describe the run they show."""

from __future__ import annotations

import asyncio
import shutil
from pathlib import Path
from typing import Any

from acquisition.messages import Instruct, Prompt
from acquisition.setup.files import setup_from_dict
from tests.tui.frozen import RUNS, ifm, positioning_session, straightness_session
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
    # on the form, in its words: the keys become the labels of their fields, the rest stays as it is
    expected = expected.replace("end_mm", "end (mm)").replace("targets_mm", "targets (mm)")
    assert expected.startswith("[axis] give end (mm)")

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


def _event(row: dict[str, Any]) -> Any:
    from tui.messages import RunDocument

    return RunDocument("event", {"data": row})


def test_after_a_redo_the_last_point_is_the_one_before_the_withdrawn_point() -> None:
    from tui.messages import RunDocument

    def screen(_app: Any) -> CaptureScreen:
        s = straightness_session("warmup")  # no points yet
        s.view.question = None
        for k in range(3):
            s.apply(_event({"station": k, "pass": 0, "x_mm": 100.0 * k, "stry_um": 0.1 * k, "sensor_mm": 0.001 * k}))
        s.apply(RunDocument("retract", {"match": {"station": 2, "pass": 0}}))  # redo: station 2 is withdrawn
        return CaptureScreen(s)

    text = show_screen(screen, check=lambda app: (widget_text(app, "#last"), widget_text(app, "#step")))
    assert text[0].startswith("last point: station 1  x 100 mm")
    assert text[1].startswith("points 2 of ")


def test_skipped_steps_count_as_done_in_the_progress() -> None:
    from tui.messages import RunDocument

    def screen(_app: Any) -> CaptureScreen:
        s = straightness_session("warmup")
        s.view.question = None
        for k in range(2):
            s.apply(_event({"station": k, "pass": 0, "x_mm": 100.0 * k, "stry_um": 0.0, "sensor_mm": 0.0}))
        s.apply(RunDocument("annotate", {"key": "skipped", "value": [{"station": 2, "pass": 0, "reason": "r"}]}))
        return CaptureScreen(s)

    # 4 stations with a return pass: 8 steps; 2 points and 1 skipped station are 3 of them
    progress = show_screen(screen, check=lambda app: app.screen.query_one("#progress").progress)
    assert progress == 3


def test_resumed_run_shows_the_points_on_disk(tmp_path: Path) -> None:
    import pandas as pd

    run = tmp_path / "runs" / "aborted"
    shutil.copytree(ROOT / RUNS / "straightness-aborted", run)
    points = pd.read_csv(run / "points.csv")
    last = points.iloc[-1]

    async def main() -> tuple[str, str, float]:
        app = GuidewayApp(runs_dir=run.parent, start="runs", simulate=True, noise=False)
        async with app.run_test(size=(80, 24)) as pilot:
            await pilot.pause()
            await pilot.press("c")
            await wait_for_app(pilot, lambda: app.session is not None and app.session.view.question is not None
                               and screen_name(app) == "QuestionScreen", what="the resume question")
            capture = app.screen_stack[-2]
            out = (str(capture.query_one("#step").render()), str(capture.query_one("#last").render()),
                   capture.query_one("#progress").progress)
            await pilot.press("a")  # abort: the run stays as it is on disk
            await wait_for_app(pilot, lambda: screen_name(app) == "ResultsScreen"
                               and app.screen.evaluation is not None, what="the results of the aborted run")
            return out

    step, last_text, progress = asyncio.run(main())
    assert step.startswith(f"points {len(points)} of ")
    assert last_text.startswith(f"last point: station {int(last['station'])}  x {last['x_mm']:g} mm")
    assert progress == len(points)


def test_runs_screen_shows_every_column_in_80_columns(tmp_path: Path) -> None:
    import json

    from tui.screens.runs import RunsScreen

    runs = tmp_path / "runs"
    shutil.copytree(ROOT / RUNS / "positioning-x", runs / "positioning-20261125T134921Z")  # a default run name
    meta = json.loads((runs / "positioning-20261125T134921Z" / "run.json").read_text())

    def check(app: Any) -> tuple[Any, Any, list[str]]:
        table = app.screen.query_one("#runs-table")
        return table.virtual_size.width, table.size.width, screen_lines(app)

    content_w, table_w, lines = show_screen(lambda _a: RunsScreen(runs), check=check)
    assert content_w <= table_w == 80  # nothing hidden to the right
    row = next(i for i, ln in enumerate(lines) if "positioning-20261125T134921Z" in ln)
    two = lines[row] + " " + lines[row + 1]
    planned = len(meta["setup"]["targets_mm"]) * meta["setup"]["runs"] * 2  # every target, both directions
    for value in ("positioning", meta["status"], f"{meta['points']}/{planned}", meta["machine"], meta["axis"],
                  meta["created"].replace("T", " ").removesuffix("Z")):
        assert f" {value} " in two, value


def test_results_show_the_files_written_and_keep_the_plot(tmp_path: Path) -> None:
    run = tmp_path / "positioning-x"
    shutil.copytree(ROOT / RUNS / "positioning-x", run)

    async def main() -> tuple[list[str], int, int]:
        app = GuidewayApp(runs_dir=tmp_path, start="runs")
        async with app.run_test(size=(80, 24)) as pilot:
            app.open_results(run)
            await wait_for_app(pilot, lambda: getattr(app.screen, "evaluation", None) is not None, what="results")
            await pilot.pause()
            before = app.screen.query_one("#plot").size.height
            for key in "1234h":  # the four compensation tables and the report, one after the other
                n = len(app.screen.written)
                await pilot.press(key)
                await wait_for_app(pilot, lambda n=n: len(app.screen.written) == n + 1, what=f"the file of {key}")
            await pilot.pause()
            await pilot.pause()
            return screen_lines(app), before, app.screen.query_one("#plot").size.height

    lines, plot_before, plot_after = asyncio.run(main())
    written = sorted(p.relative_to(run).as_posix() for p in (run / "results").iterdir())
    # the four tables, the report, and exports.json: which table was exported from this run (guideway verify)
    assert len(written) == 6 and "results/report.html" in written and "results/exports.json" in written
    # the newest path is on the screen (relative to the run directory the title names), one line each
    assert any(ln.strip() == "written: results/report.html" for ln in lines)
    shown = [ln.strip().removeprefix("written: ") for ln in lines if ln.strip().startswith("written: ")]
    assert shown and set(shown) <= set(written)
    assert plot_after >= 8 and plot_before >= 8  # the plot keeps its height: the text scrolls


def test_progress_bar_shows_its_percentage_in_80_columns() -> None:
    # 3 of 8 steps (4 stations, forward and return pass) done: 37.5 %
    lines = show_screen(lambda _a: CaptureScreen(straightness_session("capture")), check=screen_lines)
    assert lines[1].rstrip().endswith(" 38%")


def test_fault_dialog_does_not_repeat_its_title() -> None:
    prompt = Prompt("Device fault: displacement sensor (keyence-lkg on SENSOR): no reply. Check the device, then "
                    "retry, or abort the run.", ("retry", "abort"), key="fault", fault="displacement sensor: no reply")
    title, text = show_screen(lambda _a: CaptureScreen(straightness_session("capture")), modal=QuestionScreen(prompt),
                              check=lambda app: (widget_text(app, "#dialog-title"), widget_text(app, "#dialog-text")))
    assert title == "Device fault"
    assert text.startswith("displacement sensor (keyence-lkg on SENSOR): no reply. Check the device")


def test_every_set_up_label_fits_its_column() -> None:
    from tui.screens.setup import RUN_KINDS, default_source

    async def labels(kind: str) -> list[tuple[str, int]]:
        app = GuidewayApp(setup_source=default_source(kind), runs_dir=ROOT / RUNS, start="setup")
        async with app.run_test(size=(80, 24)) as pilot:
            await wait_for_app(pilot, lambda: getattr(app.screen, "ready", False), what="the set-up form")
            await pilot.pause()
            return [(str(w.render()), w.size.height) for w in app.screen.query(".label")]

    for kind, _ in RUN_KINDS:
        found = asyncio.run(labels(kind))
        assert len(found) > 5 and [h for _, h in found] == [1] * len(found), (kind, found)


def footer_after(session: Any, question: Instruct | None) -> tuple[str, str]:
    """The footer line of the capture screen once ``question`` (None: keep the session's) is pending."""
    async def main() -> tuple[str, str]:
        app = GuidewayApp(runs_dir=ROOT / RUNS, start="runs")
        async with app.run_test(size=(160, 48)) as pilot:
            app.session = session
            screen = CaptureScreen(session)
            app._switch(screen)
            await pilot.pause()
            first = screen_lines(app)[-1]
            if question is not None:
                session.view.question = question
                screen.sync_bindings()
                await pilot.pause()
            return first, screen_lines(app)[-1]

    return asyncio.run(main())


def test_the_footer_offers_only_the_choices_the_plan_offers() -> None:
    # a straightness station may be redone; a positioning target (acquisition/plans/positioning.py) can only be
    # captured, skipped, paused or aborted, so "r redo" must not be in the footer of a positioning run
    target = Instruct("target", "Target 4 (150 mm), run 1, up: capture when the axis is in position.",
                      {"target_index": 4, "run": 1, "direction": 1}, choices=("capture", "skip", "pause", "abort"),
                      key="target")
    station, positioning = footer_after(straightness_session("capture"), target)
    assert " redo " in station and " skip " in station
    assert " redo " not in positioning and " skip " in positioning and " abort " in positioning
    # at the cycle start only "started" (Space) and abort answer; redo and skip are off the footer
    cycle, _ = footer_after(positioning_session(), None)
    assert " redo " not in cycle and " skip " not in cycle and " abort " in cycle


def test_the_warm_up_override_is_offered_only_with_a_warm_up() -> None:
    with_warmup = show_screen(lambda _a: ConnectScreen(straightness_session("warmup")), size=(160, 48),
                              check=lambda app: screen_lines(app)[-1])
    without = show_screen(lambda _a: ConnectScreen(positioning_session()), size=(160, 48),
                          check=lambda app: screen_lines(app)[-1])
    assert " override warm-up " in with_warmup
    assert " override warm-up " not in without and " abort " in without


def test_a_results_file_that_cannot_be_written_is_reported(tmp_path: Path) -> None:
    # RUN/results is a file here: the results, a table and the report cannot be written (as on a full disk or
    # a read-only share); each key says so in a notification instead of doing nothing
    run = tmp_path / "positioning-x"
    shutil.copytree(ROOT / RUNS / "positioning-x", run)
    (run / "results").write_text("not a directory\n")

    async def main() -> list[tuple[str, str]]:
        app = GuidewayApp(runs_dir=tmp_path, start="runs")
        async with app.run_test(size=(80, 24)) as pilot:
            app.open_results(run)
            await wait_for_app(pilot, lambda: getattr(app.screen, "evaluation", None) is not None, what="results")
            for key in "w1h":
                n = len(app._notifications)
                await pilot.press(key)
                await wait_for_app(pilot, lambda n=n: len(app._notifications) == n + 1, what=f"the error of {key}")
            return [(n.severity, n.message) for n in app._notifications]

    shown = asyncio.run(main())
    assert len(shown) == 3 and all(severity == "error" for severity, _ in shown), shown
    assert all(str(run / "results") in message for _, message in shown), shown
    assert (run / "results").read_text() == "not a directory\n"
