"""The Results screen and the diagnosis view (issue 17): the [tolerance] verdict, only live keys, plain axis
labels, the residual of a written table, "evaluating…", the layout at 80x24 and 160x48, the diagnosis steps.

Expected values come from the command line (``guideway process / export / diagnose --json`` of the same run)
or are computed here from the value, the limit and U."""

from __future__ import annotations

import asyncio
import json
import re
import shutil
import threading
from collections.abc import Awaitable, Callable
from pathlib import Path
from typing import Any

import pytest

from tests.cli import guideway
from tests.tui.frozen import RUNS
from tests.tui.sessions import process_json, screen_lines, screen_name, widget_text
from tests.waiting import wait_for_app
from tui.app import GuidewayApp

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(autouse=True)
def _in_repository(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(ROOT)  # docs/model-positioning.toml is the diagnosis' default model


def copy_run(tmp_path: Path, name: str, **meta: Any) -> Path:
    """A copy of a saved run of tests/data/tui-runs, run.json keys replaced by ``meta``."""
    run = tmp_path / name
    shutil.copytree(ROOT / RUNS / name, run)
    if meta:
        path = run / "run.json"
        path.write_text(json.dumps({**json.loads(path.read_text()), **meta}, indent=2))
    return run


def set_tolerance(run: Path, tolerance: dict[str, Any]) -> None:
    path = run / "run.json"
    m = json.loads(path.read_text())
    m["setup"]["tolerance"] = tolerance
    path.write_text(json.dumps(m, indent=2))


def on_results(run: Path, check: Callable[[Any, Any], Awaitable[Any]], size: tuple[int, int] = (80, 24)) -> Any:
    """Open the results of ``run``, wait for the evaluation, then ``await check(app, pilot)``."""
    out: list[Any] = []

    async def main() -> None:
        app = GuidewayApp(runs_dir=run.parent, start="runs")
        async with app.run_test(size=size) as pilot:
            app.open_results(run)
            await wait_for_app(pilot, lambda: getattr(app.screen, "evaluation", None) is not None,
                               what="the evaluation", timeout_s=60)
            await pilot.pause()
            out.append(await check(app, pilot))

    asyncio.run(main())
    return out[0]


async def lines_now(app: Any, pilot: Any) -> list[str]:
    await pilot.pause()
    return screen_lines(app)


# -- the verdict ----------------------------------------------------------------------------------------------
def expected_category(value: float, limit: float, u: float | None) -> str:
    """ISO 14253-1 as the set-up's [tolerance] states it: pass when value <= limit; a value within U of the
    limit proves neither conformance nor non-conformance."""
    word = "PASS" if value <= limit else "FAIL"
    return word + (" within uncertainty" if u is not None and abs(value - limit) <= u else "")


@pytest.mark.parametrize("offset_u", [3.0, 0.5, -0.5, -3.0])
def test_the_verdict_is_shown_large_with_value_limit_and_u(tmp_path: Path, offset_u: float) -> None:
    run = copy_run(tmp_path, "straightness-bed")
    d = process_json(run)
    value = d["straightness_um"]["minimum_zone"]
    u = d["uncertainty_um"]["straightness"]["minimum_zone"]
    limit = round(value + offset_u * u, 3)
    set_tolerance(run, {"straightness_um": limit, "reference_line": "minimum_zone"})
    category = expected_category(value, limit, u)

    async def check(app: Any, pilot: Any) -> tuple[str, str, list[str]]:
        await pilot.pause()
        return widget_text(app, "#verdict-word"), widget_text(app, "#verdict-text"), screen_lines(app)

    word, text, lines = on_results(run, check)
    first = text.splitlines()[0]
    assert first.startswith(category) and (first == category or not first[len(category):].startswith(" within"))
    assert f"{value:.3f} um" in text and f"limit {limit:g} um" in text and f"U {u:.3f} um" in text
    # the word in two rows of block letters, as large as the terminal allows; on screen at 80x24
    big = {"PASS": "█▀█ ▄▀█ █▀ █▀", "FAIL": "█▀▀ ▄▀█ █ █"}[category.split()[0]]
    assert word.splitlines()[0].rstrip() == big
    assert any(big in ln for ln in lines) and any(category in ln for ln in lines)


def test_positioning_checks_show_each_value_and_limit(tmp_path: Path) -> None:
    run = copy_run(tmp_path, "positioning-x")
    iso = process_json(run)["iso230_2"]
    limits = {"A_um": round(iso["A"] * 1.5, 3), "R_um": round(iso["R"] * 0.5, 3)}  # A passes, R fails
    set_tolerance(run, limits)
    text = on_results(run, lambda app, pilot: asyncio.sleep(0, widget_text(app, "#verdict-text")))
    assert text.splitlines()[0] == "FAIL"
    assert f"R {iso['R']:.3f} um > limit {limits['R_um']:g} um" in text and "fail" in text
    assert f"A {iso['A']:.3f} um ≤ limit {limits['A_um']:g} um" in text


def test_no_verdict_without_a_tolerance(tmp_path: Path) -> None:
    run = copy_run(tmp_path, "positioning-x")
    set_tolerance(run, {})
    assert on_results(run, lambda app, pilot: asyncio.sleep(0, app.screen.query_one("#verdict").display)) is False


# -- keys, labels, title --------------------------------------------------------------------------------------
def help_keys(run: Path) -> tuple[set[str], str]:
    async def check(app: Any, pilot: Any) -> tuple[set[str], str]:
        footer = screen_lines(app)[-1]
        await pilot.press("question_mark")
        await wait_for_app(pilot, lambda: screen_name(app) == "HelpScreen", what="help")
        rows = widget_text(app, "#dialog-text").splitlines()
        return {r.split()[0] for r in rows if r.strip()}, footer

    return on_results(run, check)


def test_help_and_footer_list_only_the_keys_that_work(tmp_path: Path) -> None:
    straightness, footer_s = help_keys(copy_run(tmp_path, "straightness-bed"))
    positioning, footer_p = help_keys(copy_run(tmp_path, "positioning-x"))
    positioning_only = {"1", "2", "3", "4", "c", "k", "e"}
    straightness_only = {"m", "u"}
    assert not positioning_only & straightness and straightness_only <= straightness
    assert positioning_only <= positioning and not straightness_only & positioning
    assert {"h", "w", "d", "f3", "f2", "q", "?/F1"} <= straightness & positioning  # the help says ?/F1
    for footer in (footer_s, footer_p):
        assert " d diagnose " in footer and " h report " in footer


def test_a_rotary_run_offers_no_diagnosis(tmp_path: Path) -> None:
    # the diagnosis covers linear axes (docs/diagnosis.md): d would only print that
    run = copy_run(tmp_path, "positioning-x")
    m = json.loads((run / "run.json").read_text())
    live = on_results(run, lambda app, pilot: asyncio.sleep(0, app.screen.check_action("diagnose", ())))
    assert live and m.get("axis_type", "linear") == "linear"
    from tui.screens.results import ResultsScreen  # the same screen, told the run is rotary

    s = ResultsScreen(run)
    s.kind, s.axis_type = "positioning", "rotary"
    assert not s.check_action("diagnose", ())


def test_axis_labels_and_legend_fit_80_columns_in_plain_numbers() -> None:
    run = ROOT / RUNS / "straightness-bed"
    d = process_json(run)
    x0, x1 = d["profile"][0]["x_mm"], d["profile"][-1]["x_mm"]
    lines = on_results(run, lines_now)
    text = "\n".join(lines)
    assert not re.search(r"\de[+-]\d", text)  # no exponents
    axis = next(ln for ln in lines if "x (mm)" in ln)
    left, right = axis.split()[0], axis.split()[-1]  # the travel's ends in mm, to the mm (span 1100 mm)
    assert re.fullmatch(r"-?\d+", left) and re.fullmatch(r"-?\d+", right)
    assert float(left) == pytest.approx(x0, abs=0.5) and float(right) == pytest.approx(x1, abs=0.5)
    legend = next(ln for ln in lines if "━ profile" in ln)
    for label in ("end-point", "least squares", "minimum zone", "profile"):
        assert f"━ {label}" in legend


def test_axis_number_is_a_plain_decimal() -> None:
    from tui.widgets.plot import axis_number

    assert axis_number(1900.0, 1900.0) == "1900"  # 3 significant digits of the span: no decimals
    assert axis_number(-2.4137, 8.0) == "-2.41"
    assert axis_number(0.00012, 0.0005) == "0.0001"
    assert axis_number(-0.0001, 50.0) == "0.0"


def test_an_empty_machine_name_is_left_out_of_the_title(tmp_path: Path) -> None:
    run = copy_run(tmp_path, "positioning-x", machine="")
    title = on_results(run, lambda app, pilot: asyncio.sleep(0, widget_text(app, "#run-title")))
    assert title.split(" · ")[:3] == ["positioning", "axis X", "complete"]


# -- files ----------------------------------------------------------------------------------------------------
def test_a_written_table_shows_its_residual_as_export_json_gives_it(tmp_path: Path) -> None:
    run = copy_run(tmp_path, "positioning-x")
    other = copy_run(tmp_path / "cli", "positioning-x")
    res = guideway("export", other, "--format", "fanuc", "--model", "spline", "--json")
    assert res.returncode == 0, res.stderr
    residual = json.loads(res.stdout)["residuals"]["spline"]

    async def check(app: Any, pilot: Any) -> list[str]:
        await pilot.press("c")  # linear -> spline
        await pilot.press("2")  # Fanuc
        await wait_for_app(pilot, lambda: len(app.screen.written) == 1, what="the table")
        await pilot.pause()
        return screen_lines(app)

    lines = on_results(run, check)
    row = next(i for i, ln in enumerate(lines) if ln.strip().startswith("written: results/compensation-fanuc"))
    shown = " ".join((lines[row + 1] + " " + (lines[row + 2] if row + 2 < len(lines) else "")).split())
    assert "spline" in shown
    for key, label in (("in_sample", "in-sample"), ("leave_one_run_out", "run held out"),
                       ("leave_one_target_out", "target held out")):
        assert f"{label} {residual[key]['rms_um']:.3f} / {residual[key]['max_um']:.3f}" in shown, key


def test_written_files_do_not_push_the_title_off_the_screen(tmp_path: Path) -> None:
    run = copy_run(tmp_path, "positioning-x")

    async def check(app: Any, pilot: Any) -> list[str]:
        for key in "1234hw":
            n = len(app.screen.written)
            await pilot.press(key)
            await wait_for_app(pilot, lambda n=n: len(app.screen.written) == n + 1, what=f"the file of {key}")
        await pilot.pause()
        return screen_lines(app)

    lines = on_results(run, check)
    assert lines[1].startswith(" positioning · Machine 7 · axis X")
    assert lines[-1].lstrip().startswith("h report")  # the footer
    assert any(ln.strip() == "written: results" for ln in lines)  # the newest, last line


# -- evaluating -----------------------------------------------------------------------------------------------
def test_evaluating_is_shown_while_the_worker_evaluates_and_keys_answer(tmp_path: Path,
                                                                         monkeypatch: pytest.MonkeyPatch) -> None:
    import saved_runs.evaluation.evaluate as evaluate  # the screen's worker calls it

    run = copy_run(tmp_path, "straightness-bed")
    release = threading.Event()
    real = evaluate.process_run_dir

    def slow(*args: Any, **kw: Any) -> Any:
        release.wait(30)
        return real(*args, **kw)

    monkeypatch.setattr(evaluate, "process_run_dir", slow)

    async def main() -> tuple[str, str, str, str]:
        app = GuidewayApp(runs_dir=run.parent, start="runs")
        async with app.run_test(size=(80, 24)) as pilot:
            app.open_results(run)
            await pilot.pause()
            plot, summary = widget_text(app, "#plot"), widget_text(app, "#summary")
            await pilot.press("question_mark")  # the screen answers while the worker evaluates
            await wait_for_app(pilot, lambda: screen_name(app) == "HelpScreen", what="help", timeout_s=5)
            await pilot.press("x")
            release.set()
            await wait_for_app(pilot, lambda: getattr(app.screen, "evaluation", None) is not None, what="results")
            release.clear()
            await pilot.press("m")  # re-processing: the old results stay, the status says what is evaluated
            await pilot.pause()
            status = widget_text(app, "#written")
            plot_after = widget_text(app, "#plot")
            release.set()
            await wait_for_app(pilot, lambda: not app.screen.evaluating, what="the second evaluation")
            return plot, summary, status, plot_after

    plot, summary, status, plot_after = asyncio.run(main())
    assert plot == "evaluating…" and summary == "evaluating…"
    assert status.startswith("evaluating (method first-order")
    assert plot_after != "evaluating…" and "no points" not in plot_after


# -- sizes ----------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["straightness-bed", "positioning-x"])
def test_the_readings_are_beside_a_larger_plot_at_160x48(name: str) -> None:
    def regions(app: Any, pilot: Any) -> Any:
        q = app.screen.query_one
        return asyncio.sleep(0, (q("#plot").region, q("#summary").region))

    run = ROOT / RUNS / name
    (plot80, summary80) = on_results(run, regions)
    (plot160, summary160) = on_results(run, regions, size=(160, 48))
    assert summary80.y >= plot80.bottom  # 80x24: below the plot
    assert summary160.x >= plot160.right and summary160.y < plot160.bottom  # 160x48: beside it
    assert plot80.height >= 8 and plot160.width >= 70  # as wide as at 80x24, less the readings' column
    assert plot160.width * plot160.height >= 3 * plot80.width * plot80.height  # and much taller


# -- diagnosis ------------------------------------------------------------------------------------------------
def diagnose(run: Path, size: tuple[int, int] = (80, 24), model: str | None = None) -> tuple[Any, list[str], str]:
    async def check(app: Any, pilot: Any) -> tuple[Any, list[str], str]:
        await pilot.press("d")
        await wait_for_app(pilot, lambda: screen_name(app) == "DiagnosisScreen", what="the diagnosis")
        screen = app.screen
        if model is not None:
            await pilot.press("m")
            field = screen.query_one("#model-path")
            field.value = model
            await pilot.press("enter")
        await wait_for_app(pilot, lambda: not screen.running and (screen.result or screen.error),
                           what="the diagnosis", timeout_s=60)
        await pilot.pause()
        status = screen.query_one("#diag-status")
        return screen.result, screen_lines(app), widget_text(app, "#diag-status") if status.display else ""

    return on_results(run, check, size)


@pytest.mark.parametrize("size", [(80, 24), (160, 48)])
def test_d_shows_the_steps_of_the_diagnosis_and_the_gap_shrinking(size: tuple[int, int], tmp_path: Path) -> None:
    # the worked example of docs/diagnosis.md: a periodic error and thermal growth, named one after the other
    run = tmp_path / "worked-example"
    assert guideway("simulate", "docs/scenario-positioning.toml", "--out", run, "--seed", "1").returncode == 0
    res = guideway("diagnose", run, "--model", "docs/model-positioning.toml", "--json")
    assert res.returncode == 0, res.stderr
    expected = json.loads(res.stdout)
    _, lines, _ = diagnose(run, size)
    text = "\n".join(lines)
    assert "model file  docs/model-positioning.toml" in text  # the default: the documented model of its kind
    base = expected["baseline"]
    assert re.search(rf"^ base .*{base['rms_um']:.3f} +{base['max_um']:.3f}", text, re.M)
    assert len(expected["steps"]) >= 2
    for i, step in enumerate(expected["steps"], start=1):
        row = next(ln for ln in lines if re.match(rf"^ {i} +{step['effect']} ", ln))
        assert f"{step['rms_um']:.3f}" in row and f"{step['max_um']:.3f}" in row
        assert ("ambiguous: " + ", ".join(step["ambiguous_with"]) in row) if step["ambiguous_with"] else "named" in row
    if expected["ambiguous"]:  # (the ambiguous pairs' wording: test_the_diagnosis_view_reads_the_json_defensively)
        pairs = ", ".join(" / ".join(g) for g in expected["ambiguous"])
        assert f"ambiguous, cannot be told apart on this run: {pairs}" in " ".join(ln.strip() for ln in lines)
    # the bars: baseline, after each step, final; each as long as its RMS of the baseline's (± one cell)
    # a bar's cells: the run of block characters (the noise mark ┆ may sit inside it, or just after it)
    bars = {ln.split()[-1]: len(re.search("[█▏▎▍▌▋▊▉][█▏▎▍▌▋▊▉┆]*", ln).group().rstrip("┆"))
            for ln in lines if "█" in ln}
    full = bars[f"{base['rms_um']:.3f}"]
    for step in expected["steps"]:
        assert abs(bars[f"{step['rms_um']:.3f}"] - full * step["rms_um"] / base["rms_um"]) <= 1
    assert f"noise {expected['noise_um']:.3f} um" in text


def test_a_diagnosis_error_is_one_line(tmp_path: Path) -> None:
    model = tmp_path / "straight.toml"
    model.write_text('kind = "straightness"\n')
    _, _, status = diagnose(ROOT / RUNS / "positioning-x", model=str(model))
    assert "\n" not in status.strip() and status.startswith("cannot diagnose: ")
    assert "straightness model" in status and "positioning run" in status
    _, lines, status = diagnose(ROOT / RUNS / "positioning-x", model=str(tmp_path / "missing.toml"))
    assert status.startswith(f"cannot diagnose: model file {tmp_path / 'missing.toml'}: no such file")
    assert any(ln.startswith(" cannot diagnose: model file ") for ln in lines)  # on the screen, above the footer


def test_escape_goes_back_to_the_results() -> None:
    async def check(app: Any, pilot: Any) -> tuple[str, str]:
        await pilot.press("d")
        await wait_for_app(pilot, lambda: screen_name(app) == "DiagnosisScreen", what="the diagnosis")
        await pilot.press("m", "x")  # typed into the model field: not a key of the screen
        field = app.screen.query_one("#model-path").value
        await pilot.press("escape", "escape")
        return field, screen_name(app)

    field, name = on_results(ROOT / RUNS / "positioning-x", check)
    assert field.endswith("x") and name == "ResultsScreen"


def test_the_screens_load_without_the_evaluation_stack() -> None:
    # numpy, pandas, scipy and the evaluators take seconds to import: the workers load them, so opening the
    # results or the diagnosis never freezes the screen before "evaluating…" is shown
    import subprocess
    import sys

    code = ("import sys, tui.app, tui.screens.results, tui.screens.diagnosis; "
            "print(sorted(m for m in ('pandas', 'scipy', 'numpy') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, check=True)
    assert out.stdout.strip() == "[]"


def test_the_diagnosis_view_reads_the_json_defensively() -> None:
    # issue 19 keeps an effect's own channel (an Abbe error's pitch) in "channel" and the diagnosis channel in a
    # key of its own; labels may be missing; an RMS of 0 (a noise-free fit) is a value, not a gap
    from tui.screens.diagnosis import diagnosis_view

    d = {"channel": "deviation", "named": [], "ambiguous": [["abbe", "linear_scale"]],
         "channels": {"deviation": {"points": 12, "baseline": {"rms_um": 2.0, "max_um": 3.0},
                                    "final": {"rms_um": 0.0, "max_um": 0.0}, "noise_um": 0.5, "named": []}},
         "steps": [{"effect": "abbe", "channel": "pitch", "diagnosis_channel": "deviation", "rms_um": 0.0,
                    "max_um": 0.0, "params": {"offset_mm": 12.5, "channel": "pitch"}, "se": {"offset_mm": 0.25},
                    "evidence": {"delta_bic": -40.0, "p_value": 1e-9, "significant": True},
                    "ambiguous_with": ["linear_scale"]}]}
    table, groups = diagnosis_view(d)
    rows = table.splitlines()
    step = next(r for r in rows if r.startswith("1 "))
    assert step.split()[:4] == ["1", "abbe", "0.000", "0.000"] and "ambiguous: linear_scale" in step
    assert "offset_mm = 12.5 ± 0.25, channel = pitch" in table
    assert "ambiguous, cannot be told apart on this run: abbe / linear_scale" in table
    assert [(b.label, b.value) for b in groups[0].bars] == [("baseline", 2.0), ("+ abbe", 0.0), ("final", 0.0)]
    assert groups[0].reference == 0.5


def test_the_diagnosis_view_says_what_remains_instead_of_nothing_missing() -> None:
    # issue 19, item 3: "nothing missing" only when the final residual is white; the TUI said it whenever no
    # step was added, even with the JSON's remains saying the residual is correlated in time
    from tui.screens.diagnosis import diagnosis_view

    said = "the residual is correlated in time order (AR(1) coefficient 0.83, ...)"
    channel = {"points": 210, "baseline": {"rms_um": 0.19, "max_um": 0.6}, "final": {"rms_um": 0.19, "max_um": 0.6},
               "noise_um": 0.2, "named": []}
    white = {"channel": "deviation", "named": [], "steps": [], "channels": {"deviation": {**channel, "remains": []}}}
    wander = {**white, "channels": {"deviation": {**channel, "remains": [said]}}}
    assert "nothing significant is missing from the model" in diagnosis_view(white)[0]
    table = diagnosis_view(wander)[0]
    assert "nothing significant is missing" not in table
    assert "no effect of the library is significant, but the residual is not white" in table
    assert f"remains: {said}" in table
