"""Helpers of the TUI tests: set-ups, a key-press driver, runs compared point for point."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pandas as pd

from acquisition.messages import Instruct, Prompt
from tests.cli import guideway
from tests.waiting import wait_for_app

STRAIGHTNESS = {
    "kind": "straightness", "machine": "test bench", "axis": "X", "operator": "pilot",
    "block": {"length_mm": 100.0, "stations": 4, "samples_per_reading": 2, "return_pass": True},
    "geometry": {"mirror_mm": [50.0, 110.0, 0.0], "sensor_mm": [150.0, 0.0, 40.0]},
    "warmup": {"enabled": True, "window": 2, "interval_s": 0.05},
}

POSITIONING = {
    "kind": "positioning", "machine": "test bench", "operator": "pilot",
    "axis": {"name": "X", "type": "linear", "start_mm": 0.0, "end_mm": 200.0, "runs": 2, "overrun_mm": 2.0},
    "trigger": {"mode": "in-position", "dwell_s": 0.0, "timeout_s": 20.0},
}

# Columns that carry wall-clock time or the simulated environment's own noise and drift.
TIME_COLUMNS = ("time_s",)
ENVIRONMENT_TOLERANCE = {"air_temp_c": 0.05, "air_pressure_hpa": 0.2, "humidity_pct": 0.5, "material_temp_c": 0.05}


def screen_name(app: Any) -> str:
    """The class name of the screen on top; a device-fault dialog counts as the question dialog it is."""
    from tui.screens.dialogs import QuestionScreen

    screen = app.screen
    if not screen.is_mounted:  # still being built: a test that ends now would exit in the middle of its mount
        return "(mounting)"
    return "QuestionScreen" if isinstance(screen, QuestionScreen) else type(screen).__name__


async def press_start(pilot: Any, app: Any) -> None:
    """F5 once the set-up form is ready (it is built after the first frame)."""
    await wait_for_app(pilot, lambda: getattr(app.screen, "ready", False), what="the set-up form")
    await pilot.press("f5")


async def answer_all(pilot: Any, app: Any, prompts: dict[str, str] | None = None, *, stop_after: int | None = None,
                     timeout_s: float = 60.0) -> int:
    """Answer every question of the running session by key presses until the run ends (or ``stop_after``
    instructions): Space for an instruction, for a dialog the key of ``prompts[key]`` (default: Enter)."""
    prompts = prompts or {}
    n = 0
    session = app.session
    while True:
        await wait_for_app(pilot, lambda: session.view.question is not None or not session.active,
                           timeout_s=timeout_s, what="the next question or the end of the run")
        if session.view.question is None:
            return n
        q = session.view.question
        if isinstance(q, Prompt):
            await wait_for_app(pilot, lambda: screen_name(app) == "QuestionScreen", what="the question dialog")
            choice = prompts.get(q.key)
            await pilot.press(app.screen.keys[q.choices.index(choice)] if choice else "enter")
        else:
            assert isinstance(q, Instruct)
            if stop_after is not None and n >= stop_after:
                return n
            await wait_for_app(pilot, lambda: screen_name(app) in ("ConnectScreen", "CaptureScreen"),
                               what="a run screen")
            await pilot.press("space")
            n += 1
        await wait_for_app(pilot, lambda q=q: session.view.question is not q, what="the answer to be taken")


def read_points(run_dir: Path) -> pd.DataFrame:
    return pd.read_csv(run_dir / "points.csv")


def assert_same_points(tui_run: Path, auto_run: Path) -> None:
    """Point for point: every column equal (no-noise simulation), except wall-clock time; the simulated
    environment (its own noise and drift with time) within its noise."""
    a, b = read_points(tui_run), read_points(auto_run)
    assert list(a.columns) == list(b.columns)
    assert len(a) == len(b) > 0
    for col in a.columns:
        if col in TIME_COLUMNS:
            continue
        if col in ENVIRONMENT_TOLERANCE:
            assert (a[col] - b[col]).abs().max() <= ENVIRONMENT_TOLERANCE[col], col
        else:
            assert a[col].tolist() == b[col].tolist(), col


def process_json(run_dir: Path) -> dict[str, Any]:
    """What ``guideway process RUN_DIR --json --no-write`` prints."""
    res = guideway("process", run_dir, "--json", "--no-write")
    assert res.returncode == 0, res.stderr
    return json.loads(res.stdout)


def widget_text(app: Any, selector: str) -> str:
    return str(app.screen.query_one(selector).render())


def screen_lines(app: Any) -> list[str]:
    """The terminal lines the current screen shows (its compositor's render, as the terminal gets it)."""
    return [strip.text for strip in app.screen._compositor.render_strips()]
