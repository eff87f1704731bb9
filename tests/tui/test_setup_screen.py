"""The set-up form as a technician meets it: keys only, an 80x24 terminal, no colour needed."""

from __future__ import annotations

import asyncio
import copy
import time
from pathlib import Path
from typing import Any

from textual.widgets import Input

from acquisition.setup.maxima import STATIONS_MAX
from tests.tui.sessions import STRAIGHTNESS, screen_lines, screen_name
from tests.waiting import wait_for_app
from tui.app import GuidewayApp
from tui.screens.setup import SetupScreen

ROOT = Path(__file__).resolve().parents[2]


def run_form(check: Any, *, source: dict | None = None, simulate: bool = True, size: tuple[int, int] = (80, 24),
             setup_path: Path | None = None, ready: bool = True) -> Any:
    """Run the app on the set-up screen (once the form is built, unless ``ready`` is False), then
    ``await check(pilot, app)``."""
    out: list[Any] = []

    async def main() -> None:
        app = GuidewayApp(setup_source=copy.deepcopy(source) if source is not None else None, simulate=simulate,
                          setup_path=setup_path, runs_dir=ROOT / "tests/data/tui-runs", start="setup")
        async with app.run_test(size=size) as pilot:
            if ready:
                await wait_for_app(pilot, lambda: getattr(app.screen, "ready", False), what="the set-up form")
                await pilot.pause()
            out.append(await check(pilot, app))

    asyncio.run(main())
    return out[0]


def error_text(app: Any, field_id: str) -> str:
    err = app.screen.query_one(f"#{field_id}-error")
    return str(err.render()) if err.display else ""


def status(app: Any) -> str:
    return str(app.screen.query_one("#setup-status").render())


async def type_into(pilot: Any, app: Any, field_id: str, text: str) -> None:
    """Focus a field, clear it and type ``text`` key by key, as a technician does."""
    widget = app.screen.query_one(f"#{field_id}", Input)
    widget.focus()
    widget.value = ""
    await pilot.pause()
    await pilot.press(*text)
    await pilot.pause()


def test_ticks_and_choices_read_without_colour() -> None:
    async def check(pilot: Any, app: Any) -> list[str]:
        return screen_lines(app)

    lines = run_form(check, source={**STRAIGHTNESS, "block": {**STRAIGHTNESS["block"], "return_pass": False}})
    text = "\n".join(lines)
    assert "[x] simulated devices" in text and "[ ] return pass" in text
    assert "(•) gauge-block straightness" in text and "( ) linear positioning" in text
    assert "( ) rotary positioning" in text


def test_page_down_end_and_the_jump_list_move_the_focus_where_it_is_seen() -> None:
    async def check(pilot: Any, app: Any) -> list[tuple[str | None, bool]]:
        seen = []

        def where() -> tuple[str | None, bool]:
            f = app.screen.focused
            visible = f is not None and app.screen.query_one("#setup-form").region.contains_region(f.region)
            return (f.id if f is not None else None, visible)

        for keys in (("home",), ("pagedown",), ("pagedown",), ("end",), ("pageup",), ("f4", "5")):
            await pilot.press(*keys)
            await pilot.pause()
            seen.append(where())
        return seen

    seen = run_form(check)
    assert seen == [("setup-file", True), ("f-top-machine", True), ("f-block-length_mm", True),
                    ("f-tolerance-reference_line", True), ("f-validation-max_sensor_std_um", True),
                    ("f-sensor-protocol", True)]


def test_the_focused_field_is_marked_without_colour() -> None:
    async def check(pilot: Any, app: Any) -> tuple[str, str]:
        app.screen.query_one("#f-block-stations").focus()
        await pilot.pause()
        labels = {str(w.render()): str(w.styles.text_style) for w in app.screen.query(".label")}
        return labels["stations (incl. datum)"], labels["block length (mm)"]

    focused, other = run_form(check)
    assert "reverse" in focused and "reverse" not in other


def test_a_huge_station_count_is_refused_on_the_form_and_q_quits_at_once() -> None:
    started: list[Any] = []

    async def check(pilot: Any, app: Any) -> tuple[str, str, float]:
        app.start_run = lambda *a, **k: started.append(a)  # a run must not start
        await type_into(pilot, app, "f-block-stations", "99999999999")
        await pilot.press("f5")
        await pilot.pause()
        reason, line = error_text(app, "f-block-stations"), status(app)
        t0 = time.monotonic()
        await pilot.press("q")  # focus is in the stations field: q is no digit, it quits (the form is edited:
        await wait_for_app(pilot, lambda: screen_name(app) == "ConfirmScreen", what="the quit question")
        assert not app._exit  # it asks first)
        await pilot.press("y")
        await wait_for_app(pilot, lambda: app._exit, timeout_s=5, what="the app to quit")
        return reason, line, time.monotonic() - t0

    reason, line, quit_s = run_form(check)
    assert f"maximum of {STATIONS_MAX}" in reason and "stations (incl. datum) = 99999999999" in reason
    assert "not valid" in line and "valid:" not in line.replace("not valid", "")
    assert not started
    assert quit_s < 1.0


def test_q_types_into_a_text_field_and_quits_after_escape() -> None:
    async def check(pilot: Any, app: Any) -> tuple[str, bool, bool]:
        await type_into(pilot, app, "f-top-machine", "Quarry mill q")
        typed, quit_early = app.screen.query_one("#f-top-machine", Input).value, app._exit
        await pilot.press("escape", "q")
        await wait_for_app(pilot, lambda: screen_name(app) == "ConfirmScreen", what="the quit question")
        await pilot.press("y")
        await wait_for_app(pilot, lambda: app._exit, timeout_s=5, what="the app to quit")
        return typed, quit_early, app._exit

    typed, quit_early, quit_later = run_form(check)
    assert typed == "Quarry mill q" and not quit_early and quit_later


def test_placeholders_are_in_parentheses_and_show_the_default() -> None:
    source = {**STRAIGHTNESS, "block": {k: v for k, v in STRAIGHTNESS["block"].items() if k != "samples_per_reading"}}
    source = {k: v for k, v in source.items() if k != "operator"}

    async def check(pilot: Any, app: Any) -> dict[str, str]:
        return {i: app.screen.query_one(f"#{i}", Input).placeholder
                for i in ("f-block-samples_per_reading", "f-top-operator", "f-warmup-interval_s")}

    shown = run_form(check, source=source)
    # the loader's defaults (docs/setup-straightness.toml): 5 samples, 2 s between warm-up readings
    assert shown == {"f-block-samples_per_reading": "(default 5)", "f-top-operator": "(none)",
                     "f-warmup-interval_s": "(default 2)"}


def test_a_missing_sensor_port_is_named_and_focused_and_stays() -> None:
    source = copy.deepcopy(STRAIGHTNESS)
    source["sensor"] = {"protocol": "keyence-lkg"}
    source["controller"] = {"url": "modbus-tcp://127.0.0.1:5020"}
    started: list[Any] = []

    async def check(pilot: Any, app: Any) -> tuple[str | None, str, str, int, str]:
        app.start_run = lambda *a, **k: started.append(a)
        await pilot.press("f5")
        await pilot.pause()
        focused = app.screen.focused.id if app.screen.focused else None
        await pilot.pause(1.0)
        return focused, error_text(app, "f-sensor-port"), status(app), len(app._notifications), \
            error_text(app, "f-controller-url")

    focused, error, line, toasts, url_error = run_form(check, source=source, simulate=False)
    assert focused == "f-sensor-port"
    assert error.startswith("sensor port is missing") and "sensor port is missing" in line
    assert toasts == 0 and not started and url_error == ""


def test_every_error_is_listed_in_the_form_s_words_and_the_status_never_says_valid() -> None:
    source = copy.deepcopy(STRAIGHTNESS)
    source["block"]["length_mm"] = -100.0
    source["warmup"] = {"enabled": True, "window": 1}

    async def check(pilot: Any, app: Any) -> list[tuple[str, str, str]]:
        seen = [(error_text(app, "f-block-length_mm"), error_text(app, "f-warmup-window"), status(app))]
        await type_into(pilot, app, "f-block-length_mm", "100")
        seen.append((error_text(app, "f-block-length_mm"), error_text(app, "f-warmup-window"), status(app)))
        await type_into(pilot, app, "f-warmup-window", "5")
        seen.append((error_text(app, "f-block-length_mm"), error_text(app, "f-warmup-window"), status(app)))
        return seen

    both, one, none = run_form(check, source=source)
    assert both[0] == "block length (mm) must be a positive length, got -100.0"  # not block_length_mm
    assert both[1] == "window (readings) must be at least 2 readings, got 1"  # not [warmup] window
    assert "2 problems" in both[2]
    assert one[0] == "" and one[1] and "not valid" in one[2]
    assert none == ("", "", "set-up valid: F5 starts the run")


def test_every_error_of_a_loaded_file_is_listed(tmp_path: Path) -> None:
    text = (ROOT / "docs/setup-straightness.toml").read_text()
    text = text.replace("window = 5 ", "window = 1 ").replace("capture_attempts = 3", "capture_attempts = 3\n"
                                                                                    "colour = 1")
    text = text.replace('sensor_sign = "height"', 'sensor_sign = "sideways"')
    path = tmp_path / "bad.toml"
    path.write_text(text)

    async def check(pilot: Any, app: Any) -> tuple[str, str, str, str]:
        return error_text(app, "f-warmup-window"), error_text(app, "f-geometry-sensor_sign"), \
            str(app.screen.query_one("#file-error").render()), status(app)

    from saved_runs.toml_file import read_toml

    window, sign, unplaced, line = run_form(check, source=read_toml(path), setup_path=path)
    assert "at least 2 readings" in window and "sideways" in sign
    assert "'colour'" in unplaced and "3 problems" in line


def test_f5_starts_the_run_as_soon_as_the_set_up_is_checked(monkeypatch: Any) -> None:
    """F5 pressed while the form's fields are still being built (held back here) starts the run from
    the checked set-up: it is not refused as "still loading"."""
    started: list[Any] = []
    held: list[Any] = []
    monkeypatch.setattr(SetupScreen, "_prepared", lambda self, *a: held.append((self, a)))

    async def check(pilot: Any, app: Any) -> int:
        app.start_run = lambda *a, **k: started.append(a)
        await pilot.press("f5")
        await wait_for_app(pilot, lambda: bool(started), timeout_s=30, what="the run to start")
        await pilot.press("f5")
        await pilot.pause()
        return len(app._notifications)

    toasts = run_form(check, source=STRAIGHTNESS, ready=False)
    assert len(started) == 1 and toasts == 0
    assert started[0][0] == STRAIGHTNESS  # the set-up as given


def test_the_wide_form_puts_sections_side_by_side() -> None:
    async def check(pilot: Any, app: Any) -> tuple[int, int, int, int]:
        a = app.screen.query_one("#f-top-machine").region
        b = app.screen.query_one("#f-block-length_mm").region
        return a.x, b.x, a.y, b.y

    ax, bx, ay, by = run_form(check, size=(160, 48))
    assert bx > ax + 40 and abs(by - ay) <= 1  # Block and stations beside Run, not below it
    assert isinstance(SetupScreen, type)


def test_an_empty_station_count_is_asked_for_in_the_form_s_words() -> None:
    async def check(pilot: Any, app: Any) -> str:
        await type_into(pilot, app, "f-block-stations", "")
        return error_text(app, "f-block-stations")

    assert run_form(check, source=STRAIGHTNESS).startswith("give the stations")
