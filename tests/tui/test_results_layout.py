"""Results screen layout at 80x24 (issue 25): a second compensation table does not push the newest one's
residual off the screen, and the values under the plot can be reached with the keyboard."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from tests.cli import guideway
from tests.tui.sessions import screen_lines
from tests.tui.test_results_screen import copy_run, on_results
from tests.waiting import wait_for_app


def in_view(app: Any, selector: str) -> bool:
    """Is the whole of widget ``selector`` inside the screen's visible region (not clipped by its parents)?"""
    w = app.screen.query_one(selector)
    return w.region.height > 0 and app.screen.region.contains_region(w.region) \
        and w.parent.region.contains_region(w.region)


def test_the_newest_export_and_its_residual_stay_visible_after_two_at_80x24(tmp_path: Path) -> None:
    run = copy_run(tmp_path, "positioning-x")
    other = copy_run(tmp_path / "cli", "positioning-x")
    res = guideway("export", other, "--format", "fanuc", "--model", "linear", "--json")
    assert res.returncode == 0, res.stderr
    residual = json.loads(res.stdout)["residuals"]["linear"]

    async def check(app: Any, pilot: Any) -> tuple[list[str], bool]:
        for key in "12":  # LinuxCNC, then Fanuc: the Fanuc table is the newest
            n = len(app.screen.written)
            await pilot.press(key)
            await wait_for_app(pilot, lambda n=n: len(app.screen.written) == n + 1, what=f"the table of {key}")
        await pilot.pause()
        return screen_lines(app), in_view(app, "#written")

    lines, visible = on_results(run, check)
    assert visible
    text = " ".join(" ".join(lines).split())
    assert "written: results/compensation-fanuc.txt" in text
    for key, label in (("in_sample", "in-sample"), ("leave_one_run_out", "run held out"),
                       ("leave_one_target_out", "target held out")):
        # the newest table's residual, whole, as guideway export --json gives it
        assert f"{label} {residual[key]['rms_um']:.3f} / {residual[key]['max_um']:.3f}" in text, key
    assert "compensation-linuxcnc.comp" in text  # the earlier one still named
    assert lines[1].startswith(" positioning · Machine 7")  # the title stays


def test_page_down_reaches_the_values_under_the_plot_at_80x24(tmp_path: Path) -> None:
    run = copy_run(tmp_path, "positioning-x")

    async def check(app: Any, pilot: Any) -> tuple[list[str], list[str]]:
        for key in "12":
            n = len(app.screen.written)
            await pilot.press(key)
            await wait_for_app(pilot, lambda n=n: len(app.screen.written) == n + 1, what=f"the table of {key}")
        await pilot.pause()
        before = screen_lines(app)
        for _ in range(3):
            await pilot.press("pagedown")
        await pilot.pause()
        return before, screen_lines(app)

    before, after = on_results(run, check)
    # the model line (c) and the bidirectional accuracy are below the plot, off the screen before the keys
    assert not any("model linear" in ln for ln in before)
    assert any("model linear" in ln for ln in after)
    assert any("compensation-fanuc" in ln for ln in after)  # the status line stays where it is
