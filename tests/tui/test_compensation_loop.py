"""The compensation loop in the TUI (issue 26; docs/tui.md "The compensation loop"): from the Results screen of
an as-found run export a table, read its load steps, measure again with it (simulated controller), verify the
as-left run; with real devices a confirm dialog first; the runs browser's found/left marks and its ``v``.

Expected values are computed here: ISO 230-2 E from the two runs' points.csv (the formula written below,
standards.md §1.3), the SHA-256 with hashlib, the load steps from ``guideway export --json`` of a copy."""

from __future__ import annotations

import asyncio
import hashlib
import json
import re
import shutil
from pathlib import Path
from typing import Any

import pandas as pd
import pytest

from tests.cli import guideway
from tests.tui.sessions import answer_all, process_json, screen_lines, screen_name, widget_text
from tests.waiting import wait_for_app
from tui.app import GuidewayApp

ROOT = Path(__file__).resolve().parents[2]
RUNS = ROOT / "tests/data/tui-runs"

# a short simulated axis; the controller reports the axis at 20 C (readings_compensated), so a deviation is
# reading - target and E can be computed from points.csv alone
SETUP_TOML = """kind = "positioning"
machine = "test bench"
operator = "pilot"
[axis]
name = "X"
type = "linear"
start_mm = 0.0
end_mm = 200.0
runs = 2
overrun_mm = 2.0
[trigger]
mode = "in-position"
dwell_s = 0.0
timeout_s = 20.0
[environment]
readings_compensated = true
"""


def iso_e_um(run_dir: Path) -> float:
    """ISO 230-2 bidirectional systematic positional deviation E = max - min over the targets and both
    directions of the mean deviation x̄_i↑, x̄_i↓ (um), from points.csv: deviation = reading - target."""
    pts = pd.read_csv(run_dir / "points.csv")
    pts["e_um"] = (pts["reading_mm"] - pts["target_mm"]) * 1000.0
    means = pts.groupby(["target_mm", "direction"])["e_um"].mean()
    return float(means.max() - means.min())


@pytest.fixture(scope="module")
def found(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """An as-found run measured by ``guideway acquire --simulate --auto`` (run.json keeps its set-up)."""
    tmp = tmp_path_factory.mktemp("loop-tui")
    setup = tmp / "setup.toml"
    setup.write_text(SETUP_TOML, encoding="utf-8")
    runs = tmp / "runs"
    runs.mkdir()
    res = guideway("acquire", "positioning", "--setup", setup, "--out", runs / "found", "--simulate", "--auto",
                   "--seed", "3")
    assert res.returncode == 0, res.stderr
    return runs / "found"


def value_row(text: str, name: str) -> dict[str, str]:
    """The printed figures of one row of the Verify screen's value table."""
    for line in text.splitlines():
        m = re.match(rf"^{re.escape(name)}\s+(\S+) ± (\S+)\s+(\S+) ± (\S+)\s+(\S+)\s+(\S+) ± (\S+) %\s+(\S+)", line)
        if m:
            keys = ("found", "u_found", "left", "u_left", "predicted", "reduction", "u_reduction", "agrees")
            return dict(zip(keys, m.groups(), strict=True))
    raise AssertionError(f"no row {name!r} in:\n{text}")


def test_export_measure_again_and_verify_in_simulation(found: Path, tmp_path: Path) -> None:
    runs = found.parent
    # the load steps the command line prints for the same table (a copy of the run: the file name is the same)
    copy = tmp_path / "found"
    shutil.copytree(found, copy)
    res = guideway("export", copy, "--format", "linuxcnc", "--json")
    assert res.returncode == 0, res.stderr
    cli_steps = json.loads(res.stdout)["load"]
    out: dict[str, Any] = {}

    async def main() -> None:
        app = GuidewayApp(runs_dir=runs, start="runs", simulate=True, seed=0)
        async with app.run_test(size=(80, 24)) as pilot:
            app.open_results(found)
            await wait_for_app(pilot, lambda: getattr(app.screen, "evaluation", None) is not None,
                               what="the evaluation", timeout_s=60)
            results = app.screen
            out["n_before"] = results.check_action("measure_again", ())
            out["v_on_found"] = results.check_action("verify", ())
            await pilot.press("1")
            await wait_for_app(pilot, lambda: results.table is not None, what="the table", timeout_s=60)
            await pilot.pause()
            out["load"] = widget_text(app, "#load")
            out["lines_after_export"] = screen_lines(app)
            await pilot.press("n")
            await wait_for_app(pilot, lambda: app.session is not None, what="the as-left run to start")
            out["left_dir"] = app.session.out
            await answer_all(pilot, app, timeout_s=90)
            await wait_for_app(pilot, lambda: screen_name(app) == "ResultsScreen"
                               and getattr(app.screen, "evaluation", None) is not None,
                               what="the as-left run's results", timeout_s=60)
            await pilot.pause()
            out["left_title"] = widget_text(app, "#run-title")
            out["v_on_left"] = app.screen.check_action("verify", ())
            await pilot.press("v")
            await wait_for_app(pilot, lambda: screen_name(app) == "VerifyScreen", what="the Verify screen")
            verify = app.screen
            await wait_for_app(pilot, lambda: verify.verification is not None or bool(verify.problem),
                               what="the verification", timeout_s=90)
            await pilot.pause()
            out["problem"] = verify.problem
            out["values"] = widget_text(app, "#verify-values")
            out["verdict"] = widget_text(app, "#verify-verdict")
            out["table"] = widget_text(app, "#verify-table")
            out["verify_lines"] = screen_lines(app)
            await pilot.press("escape")
            await pilot.pause()
            out["after_escape"] = screen_name(app)

    asyncio.run(main())
    table = found / "results" / "compensation-linuxcnc.comp"
    sha = hashlib.sha256(table.read_bytes()).hexdigest()
    # the export: its load steps, as guideway export prints them, and the next step offered
    assert out["n_before"] is False and out["v_on_found"] is False
    load = " ".join(out["load"].split())
    for step in cli_steps:
        assert " ".join(step.split()) in load, step
    assert f"sha256 {sha[:12]}" in load and "n measure again" in load and "found-left" in load
    assert any("n measure again" in ln for ln in out["lines_after_export"])  # in the footer at 80x24
    # the as-left run: beside the found run, named after it, measured with the table, the next simulated seed
    left = out["left_dir"]
    assert left == runs / "found-left"
    meta = json.loads((left / "run.json").read_text())
    assert meta["compensation"]["sha256"] == sha and meta["compensation"]["applied_by"] == "simulated controller"
    assert meta["simulation"]["seed"] == json.loads((found / "run.json").read_text())["simulation"]["seed"] + 1
    assert meta["setup"]["targets_mm"] == json.loads((found / "run.json").read_text())["setup"]["targets_mm"]
    assert "as-left of found" in out["left_title"] and out["v_on_left"] is True
    # the Verify screen: E found, left and the reduction, to the printed digits, from the points
    assert not out["problem"]
    e_found, e_left = iso_e_um(found), iso_e_um(left)
    row = value_row(out["values"], "E")
    assert row["found"] == f"{e_found:.3f}" and row["left"] == f"{e_left:.3f}"
    assert row["reduction"] == f"{100.0 * (1.0 - abs(e_left) / abs(e_found)):.1f}"
    assert e_found > 3.0 and e_left < e_found / 3  # the table works (the simulated axis has several um)
    for name in ("M", "B", "A", "R"):
        value_row(out["values"], name)
    assert "the table exported from AS_FOUND" in " ".join(out["table"].split())
    assert " ".join(out["verdict"].split()).startswith(f"verdict: E {e_found:.3f} -> {e_left:.3f} um")
    # readable at 80x24: the verdict and E's row on the first screen
    assert any(ln.strip().startswith("verdict: E") for ln in out["verify_lines"])
    assert any(re.match(r"^\s*E\s+\d", ln) for ln in out["verify_lines"])
    assert out["after_escape"] == "ResultsScreen"


CONTROLLER = "modbus-tcp://127.0.0.1:9"  # nothing listens there: a run that is started does not get far


def real_found(tmp_path: Path) -> Path:
    """A saved positioning run measured with real devices (no ``simulation`` record)."""
    run = tmp_path / "runs" / "positioning-x"
    shutil.copytree(RUNS / "positioning-x", run)
    meta = json.loads((run / "run.json").read_text())
    meta.pop("simulation")
    meta["setup_source"]["controller"] = {"url": CONTROLLER}
    (run / "run.json").write_text(json.dumps(meta))
    return run


def confirm_dialog(run: Path, answer: str, *, record: bool = True) -> dict[str, Any]:
    """Results of ``run`` (real devices), key 1, key n, then ``answer`` in the confirm dialog; ``record``:
    ``start_run`` is recorded, not run (there is no controller to connect to here)."""
    out: dict[str, Any] = {"started": []}

    async def main() -> None:
        app = GuidewayApp(runs_dir=run.parent, start="runs")
        if record:
            app.start_run = lambda *a, **k: out["started"].append((a, k))  # type: ignore[method-assign]
        async with app.run_test(size=(80, 24)) as pilot:
            app.open_results(run)
            await wait_for_app(pilot, lambda: getattr(app.screen, "evaluation", None) is not None,
                               what="the evaluation", timeout_s=60)
            results = app.screen
            await pilot.press("1")
            await wait_for_app(pilot, lambda: results.table is not None, what="the table", timeout_s=60)
            await pilot.press("n")
            await wait_for_app(pilot, lambda: screen_name(app) == "ConfirmScreen", what="the confirm dialog")
            out["dialog"] = " ".join((widget_text(app, "#dialog-title") + " " + widget_text(app, "#dialog-text"))
                                     .split())
            await pilot.press(answer)
            await pilot.pause()
            out["after"] = screen_name(app)
            out["session"] = app.session
            if not record:  # the run starts, cannot open the controller and ends: back on the found run's results
                await wait_for_app(pilot, lambda: screen_name(app) == "ResultsScreen" and app.screen is not results,
                                   what="the results again", timeout_s=30)
                await pilot.pause()
                out["back"] = (app.screen.run_dir, widget_text(app, "#run-title"))

    asyncio.run(main())
    return out


def test_real_devices_ask_before_measuring_again_and_a_no_starts_nothing(tmp_path: Path) -> None:
    run = real_found(tmp_path)
    out = confirm_dialog(run, "n")
    table = run / "results" / "compensation-linuxcnc.comp"
    sha = hashlib.sha256(table.read_bytes()).hexdigest()
    assert "loaded in the controller" in out["dialog"]
    assert str(table) in out["dialog"] and f"sha256 {sha[:12]}…" in out["dialog"]
    assert out["started"] == [] and out["session"] is None and out["after"] == "ResultsScreen"
    assert not (run.parent / "positioning-x-left").exists()


def test_real_devices_yes_starts_the_as_left_run_with_the_table(tmp_path: Path) -> None:
    run = real_found(tmp_path)
    (run.parent / "positioning-x-left").mkdir()  # an earlier as-left run: never overwritten
    out = confirm_dialog(run, "y")
    ((source, out_dir), kwargs), = out["started"]
    table = run / "results" / "compensation-linuxcnc.comp"
    assert out_dir == run.parent / "positioning-x-left-2" and kwargs["simulate"] is False
    assert source["compensation"] == {"file": str(table.resolve()), "format": "linuxcnc", "comp_file_type": 1}
    stored = json.loads((run / "run.json").read_text())["setup_source"]
    assert {k: v for k, v in source.items() if k != "compensation"} == stored


def test_a_run_that_does_not_start_comes_back_to_the_found_runs_results(tmp_path: Path) -> None:
    run = real_found(tmp_path)
    out = confirm_dialog(run, "y", record=False)
    where, title = out["back"]
    assert where == run and "did not start" in title and "127.0.0.1:9" in " ".join(title.split())


def refused_n(run: Path, after_export: Any = None) -> dict[str, Any]:
    """Results of ``run`` (real devices), key 1, ``after_export(table)``, key n: what is on screen after it."""
    out: dict[str, Any] = {}

    async def main() -> None:
        app = GuidewayApp(runs_dir=run.parent, start="runs")
        async with app.run_test(size=(80, 24)) as pilot:
            app.open_results(run)
            await wait_for_app(pilot, lambda: getattr(app.screen, "evaluation", None) is not None,
                               what="the evaluation", timeout_s=60)
            results = app.screen
            await pilot.press("1")
            await wait_for_app(pilot, lambda: results.table is not None, what="the table", timeout_s=60)
            if after_export is not None:
                after_export(results.table.path)
            await pilot.press("n")
            await pilot.pause()
            out["screen"] = screen_name(app)
            out["session"] = app.session
            out["notes"] = [str(n.message) for n in app._notifications]

    asyncio.run(main())
    return out


def test_no_controller_in_the_set_up_is_said_before_asking(tmp_path: Path) -> None:
    run = real_found(tmp_path)
    meta = json.loads((run / "run.json").read_text())
    del meta["setup_source"]["controller"]
    (run / "run.json").write_text(json.dumps(meta))
    out = refused_n(run)
    assert out["screen"] == "ResultsScreen" and out["session"] is None
    assert any("names no controller" in n for n in out["notes"])


def test_a_table_changed_after_it_was_written_is_refused(tmp_path: Path) -> None:
    run = real_found(tmp_path)
    out = refused_n(run, lambda table: table.write_text(table.read_text() + "0.0 0.0 0.0\n"))
    assert out["screen"] == "ResultsScreen" and out["session"] is None  # no dialog for other bytes
    assert any("changed since it was written" in n for n in out["notes"])


def test_a_csv_table_shows_its_steps_but_offers_no_measurement(tmp_path: Path) -> None:
    run = real_found(tmp_path)
    out: dict[str, Any] = {}

    async def main() -> None:
        app = GuidewayApp(runs_dir=run.parent, start="runs")
        async with app.run_test(size=(80, 24)) as pilot:
            app.open_results(run)
            await wait_for_app(pilot, lambda: getattr(app.screen, "evaluation", None) is not None,
                               what="the evaluation", timeout_s=60)
            results = app.screen
            await pilot.press("4")
            await wait_for_app(pilot, lambda: "compensation-csv" in widget_text(app, "#load"), what="the steps",
                               timeout_s=60)
            out["load"] = widget_text(app, "#load")
            out["n"] = results.check_action("measure_again", ())

    asyncio.run(main())
    assert "plain table" in " ".join(out["load"].split()) and out["n"] is False
    assert "n measure again" not in " ".join(out["load"].split())


# -- the runs browser ---------------------------------------------------------------------------------------------
def pair_folder(tmp_path: Path) -> dict[str, Path]:
    """found (a table exported by guideway export, recorded in its exports.json), left (run.json: measured with
    that table), stranger (measured with a table no run here exported), copy (found's results/ copied into a
    run of another uid: its record names found's uid, so it exports nothing)."""
    runs = tmp_path / "runs"
    runs.mkdir()
    found = runs / "found"
    shutil.copytree(RUNS / "positioning-x", found)
    assert guideway("export", found, "--format", "linuxcnc").returncode == 0
    table = found / "results" / "compensation-linuxcnc.comp"
    sha = hashlib.sha256(table.read_bytes()).hexdigest()

    def run(name: str, created: str, sha256: str | None, uid: str) -> Path:
        path = runs / name
        shutil.copytree(RUNS / "positioning-x", path)
        meta = json.loads((path / "run.json").read_text())
        meta.update(created=created, uid=uid, compensation={"active": False} if sha256 is None else {
            "active": True, "file": table.name, "path": str(table), "format": "linuxcnc", "sha256": sha256,
            "comp_file_type": 1, "applied_by": "simulated controller"})
        (path / "run.json").write_text(json.dumps(meta))
        return path

    left = run("left", "2026-11-27T10:00:00Z", sha, "uid-left")
    stranger = run("stranger", "2026-11-27T11:00:00Z", "0" * 64, "uid-stranger")
    copy = run("copy", "2026-11-26T10:00:00Z", None, "uid-copy")
    shutil.copytree(found / "results", copy / "results", dirs_exist_ok=True)
    return {"runs": runs, "found": found, "left": left, "stranger": stranger, "copy": copy}


def test_the_runs_browser_marks_found_left_pairs_and_v_verifies(tmp_path: Path) -> None:
    f = pair_folder(tmp_path)
    out: dict[str, Any] = {}

    async def main() -> None:
        app = GuidewayApp(runs_dir=f["runs"], start="runs")
        async with app.run_test(size=(80, 24)) as pilot:
            await wait_for_app(pilot, lambda: screen_name(app) == "RunsScreen" and bool(app.screen.runs),
                               what="the runs browser")
            screen = app.screen
            order = [r.path.name for r in screen.runs]
            out["order"] = order
            out["lines"] = screen_lines(app)
            out["marks"] = {name: screen.pair_text(f[name]) for name in ("found", "left", "stranger", "copy")}
            out["v"] = {}
            for name in order:  # v is offered on the as-left run only
                await pilot.press("home")
                for _ in range(order.index(name)):
                    await pilot.press("down")
                await pilot.pause()
                out["v"][name] = screen.check_action("verify", ())
                if name == "left":
                    out["detail"] = widget_text(app, "#run-detail")
                    out["footer"] = screen_lines(app)[-1]
                    await pilot.press("v")
                    await wait_for_app(pilot, lambda: screen_name(app) == "VerifyScreen", what="the Verify screen")
                    out["pushed"] = (app.screen.found, app.screen.left)
                    await pilot.press("escape")
                    await wait_for_app(pilot, lambda: screen_name(app) == "RunsScreen", what="back to the browser")

    asyncio.run(main())
    assert out["marks"] == {"found": "found, left: left", "left": "left of found", "stranger": "", "copy": ""}
    text = "\n".join(out["lines"])
    assert "left of" in text and "found, left:" in text
    assert out["v"] == {"stranger": False, "left": True, "copy": False, "found": False}
    assert "v verifies it against found" in " ".join(out["detail"].split()) and "v verify" in out["footer"]
    assert out["pushed"] == (f["found"], f["left"])


@pytest.mark.parametrize("size", [(80, 24), (160, 48)])
def test_the_verify_screen_at_80x24_and_160x48(tmp_path: Path, size: tuple[int, int]) -> None:
    f = pair_folder(tmp_path)  # left holds found's own points: nothing removed, E found = E left
    out: dict[str, Any] = {}

    async def main() -> None:
        from tui.screens.verify import VerifyScreen

        app = GuidewayApp(runs_dir=f["runs"], start="runs")
        async with app.run_test(size=size) as pilot:
            await wait_for_app(pilot, lambda: screen_name(app) == "RunsScreen", what="the runs browser")
            screen = VerifyScreen(f["found"], f["left"])
            app.push_screen(screen)
            await wait_for_app(pilot, lambda: screen.verification is not None or bool(screen.problem),
                               what="the verification", timeout_s=60)
            await pilot.pause()
            out["problem"] = screen.problem
            out["values"] = widget_text(app, "#verify-values")
            out["first"] = screen_lines(app)
            await pilot.press("pagedown", "pagedown", "pagedown")
            await pilot.pause()
            out["later"] = screen_lines(app)

    asyncio.run(main())
    e = process_json(f["found"])["iso230_2"]["E"]  # positioning-x's readings need the environment: process's E
    assert not out["problem"]
    first = "\n".join(out["first"])
    assert "verdict: E" in first and f"{e:.3f}" in first
    if size[0] == 80:  # the compact table: E's row on the first screen, 0 % removed; the notes scrolled to
        row = value_row(out["values"], "E")
        assert row["found"] == row["left"] == f"{e:.3f}" and row["reduction"] == "0.0"
        assert any(ln.startswith(" note:") for ln in out["later"])
    else:  # the command line's own value lines, with the predicted values as a repeat shows them
        assert "again" in out["values"] and "pred." in out["values"]
        assert any(ln.strip().startswith("E ") and f"{e:.3f}" in ln for ln in out["first"])
