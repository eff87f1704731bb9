"""The set-up form under a technician's hands (issue 25): the highlight follows the focus, a key never
replaces a value out of sight, ``?`` / F1 help, the tolerance on the form, the runs = 1 warning, asking
before quitting an edited form and before overwriting a file, a start error that stays, NO_COLOR contrast."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
from textual.widgets import Input

from acquisition.setup.files import setup_from_dict
from saved_runs.toml_file import read_toml
from tests.tui.sessions import STRAIGHTNESS, screen_lines, screen_name
from tests.tui.test_setup_screen import ROOT, error_text, run_form, status, type_into
from tests.waiting import wait_for_app

POSITIONING = read_toml(ROOT / "docs/setup-positioning.toml")


def reversed_labels(app: Any) -> list[str]:
    """The labels drawn in reverse video now (from the rendered style, not the CSS rule)."""
    return [str(w.render()) for w in app.screen.query(".label") if "reverse" in str(w.styles.text_style)]


def focused_label(app: Any) -> str | None:
    """The label of the row holding the focused widget, found by walking the DOM (None: no labelled row)."""
    node = app.screen.focused
    while node is not None and not node.has_class("row"):
        node = node.parent
    if node is None:
        return None
    labels = [w for w in node.children if w.has_class("label")]
    return str(labels[0].render()) if labels else None


def test_the_highlight_follows_tab_through_every_field() -> None:
    async def check(pilot: Any, app: Any) -> list[tuple[str | None, str | None, list[str]]]:
        seen = []
        focusable = [w for w in app.screen.query("*") if w.focusable]
        for _ in range(len(focusable) + 1):  # once round the whole form
            await pilot.press("tab")
            await pilot.pause()
            f = app.screen.focused
            seen.append((f.id if f is not None else None, focused_label(app), reversed_labels(app)))
        return seen

    seen = run_form(check)
    assert len({s[0] for s in seen}) > 30  # every field was visited
    for fid, label, shown in seen:
        assert shown == ([label] if label is not None else []), (fid, label, shown)


def test_focusing_a_field_does_not_select_its_value_so_a_key_never_replaces_it() -> None:
    async def check(pilot: Any, app: Any) -> tuple[str, str, str]:
        app.screen.query_one("#f-top-machine").focus()
        await pilot.pause()
        await pilot.press("tab")  # to axis, then operator, as a technician tabs
        await pilot.press("tab")
        await pilot.press("Z")
        operator = app.screen.query_one("#f-top-operator", Input).value
        app.screen.query_one("#f-block-samples_per_reading").focus()
        await pilot.press("shift+tab")  # back to the stations field
        await pilot.press("7")
        await pilot.pause()
        return operator, app.screen.query_one("#f-block-stations", Input).value, \
            app.screen.query_one("#f-block-length_mm", Input).value

    operator, stations, length = run_form(check, source=STRAIGHTNESS)
    assert operator == STRAIGHTNESS["operator"] + "Z"  # typed at the end, not in place of the name
    assert stations == f"{STRAIGHTNESS['block']['stations']}7"
    assert length == f"{STRAIGHTNESS['block']['length_mm']:g}"


@pytest.mark.parametrize("field", ["f-top-operator", "f-block-length_mm", "f-block-return_pass",
                                   "f-geometry-sensor_sign", "setup-file"])
def test_question_mark_opens_help_from_any_field_and_keeps_the_value(field: str) -> None:
    async def check(pilot: Any, app: Any) -> tuple[str, Any, Any]:
        widget = app.screen.query_one(f"#{field}")
        widget.focus()
        await pilot.pause()
        before = widget.value
        await pilot.press("question_mark")
        await wait_for_app(pilot, lambda: screen_name(app) == "HelpScreen", what="help", timeout_s=5)
        await pilot.press("escape")
        await pilot.pause()
        return screen_name(app), before, widget.value

    name, before, after = run_form(check)
    assert name == "SetupScreen" and before == after


def test_question_mark_is_typed_in_a_url_and_f1_opens_help_there() -> None:
    async def check(pilot: Any, app: Any) -> tuple[str, str]:
        await type_into(pilot, app, "f-controller-url", "modbus-rtu:/dev/ttyUSB1?baud=19200")
        typed = app.screen.query_one("#f-controller-url", Input).value
        await pilot.press("f1")
        await wait_for_app(pilot, lambda: screen_name(app) == "HelpScreen", what="help", timeout_s=5)
        return typed, screen_name(app)

    typed, name = run_form(check)
    assert typed == "modbus-rtu:/dev/ttyUSB1?baud=19200" and name == "HelpScreen"


def test_straightness_tolerance_typed_on_the_form_reaches_the_set_up(tmp_path: Path) -> None:
    source = {k: v for k, v in STRAIGHTNESS.items() if k != "tolerance"}

    async def check(pilot: Any, app: Any) -> tuple[dict, dict, str, str]:
        screen = app.screen
        before = dict(screen.source.get("tolerance") or {})
        await type_into(pilot, app, "f-tolerance-straightness_um", "-3")
        bad = error_text(app, "f-tolerance-straightness_um")
        await type_into(pilot, app, "f-tolerance-straightness_um", "12.5")
        screen.query_one("#f-tolerance-reference_line").focus()
        await pilot.press("right")  # minimum_zone -> least_squares
        await pilot.pause()
        return before, dict(screen.source["tolerance"]), bad, status(app)

    before, after, bad, line = run_form(check, source=source)
    assert before == {}  # a form without a limit gives no [tolerance] (the line alone is none)
    assert "straightness (um)" in bad and "positive" in bad
    assert after == {"straightness_um": 12.5, "reference_line": "least_squares"}
    assert "set-up valid" in line
    assert setup_from_dict({**source, "tolerance": after}).tolerance == after


def test_positioning_runs_1_warns_that_a_and_r_are_not_evaluated() -> None:
    source = {**POSITIONING, "axis": {**POSITIONING["axis"], "runs": 5},
              "tolerance": {"E_um": 15.0}}

    async def check(pilot: Any, app: Any) -> tuple[str, str, str, dict, str]:
        quiet = app.screen.query_one("#f-axis-runs-warning").display
        await type_into(pilot, app, "f-axis-runs", "1")
        warn_e = str(app.screen.query_one("#f-axis-runs-warning").render())
        await type_into(pilot, app, "f-tolerance-A_um", "20")
        warn_a = str(app.screen.query_one("#f-axis-runs-warning").render())
        return quiet, warn_e, warn_a, dict(app.screen.source["tolerance"]), status(app)

    quiet, warn_e, warn_a, tolerance, line = run_form(check, source=source)
    assert quiet is False
    assert "1 run per direction cannot give A or R" in warn_e and "NOT EVALUATED" not in warn_e
    assert "limit on A will be NOT EVALUATED" in warn_a
    assert tolerance == {"E_um": 15.0, "A_um": 20.0}
    assert "set-up valid" in line and "cannot give A or R" in line


def test_q_on_an_unedited_form_quits_and_n_keeps_an_edited_one() -> None:
    async def check(pilot: Any, app: Any) -> tuple[bool, str, str]:
        await type_into(pilot, app, "f-block-stations", "12")
        app.screen.set_focus(None)
        await pilot.press("q")
        await wait_for_app(pilot, lambda: screen_name(app) == "ConfirmScreen", what="the quit question")
        text = "\n".join(screen_lines(app))
        await pilot.press("n")
        await pilot.pause()
        return app._exit, screen_name(app), text

    exited, name, text = run_form(check)
    assert not exited and name == "SetupScreen" and "not saved" in text

    async def untouched(pilot: Any, app: Any) -> bool:
        await pilot.press("q")
        await wait_for_app(pilot, lambda: app._exit, timeout_s=5, what="the app to quit")
        return app._exit

    assert run_form(untouched)


def test_a_start_error_stays_on_the_form_in_plain_words() -> None:
    port = "/dev/ttyUSB_t25_absent"  # real devices, a port that does not exist: the serial driver refuses it
    source = {**STRAIGHTNESS, "sensor": {**STRAIGHTNESS.get("sensor", {}), "port": port},
              "controller": {**STRAIGHTNESS.get("controller", {}), "url": "modbus-tcp://192.0.2.1:502"}}

    async def check(pilot: Any, app: Any) -> tuple[str, str]:
        await pilot.press("f5")
        await wait_for_app(pilot, lambda: app.session is not None and not app.session.active and
                           screen_name(app) == "SetupScreen", what="the run to end", timeout_s=20)
        await pilot.pause()
        first = "\n".join(screen_lines(app))
        await pilot.pause(11)  # a toast would be gone by now
        return first, "\n".join(screen_lines(app))

    first, later = run_form(check, source=source, simulate=False)
    for text in (first, later):
        assert f"The sensor port {port} does not exist." in text
        assert "[Errno" not in text and "but the run did not start" in text
    assert later.count("The run did not start") == 1


def contrast(fg: Any, bg: Any) -> float:
    """WCAG 2 contrast ratio of two colours (relative luminance of sRGB)."""
    def lum(c: Any) -> float:
        def ch(v: int) -> float:
            x = v / 255
            return x / 12.92 if x <= 0.03928 else ((x + 0.055) / 1.055) ** 2.4
        r, g, b = c
        return 0.2126 * ch(r) + 0.7152 * ch(g) + 0.0722 * ch(b)
    hi, lo = sorted((lum(fg), lum(bg)), reverse=True)
    return (hi + 0.05) / (lo + 0.05)


def test_errors_under_no_color_are_readable(monkeypatch: Any) -> None:
    monkeypatch.setenv("NO_COLOR", "1")
    source = {**STRAIGHTNESS, "block": {**STRAIGHTNESS["block"], "length_mm": -5.0}}

    async def check(pilot: Any, app: Any) -> list[tuple[float, bool]]:
        widget = app.screen.query_one("#f-block-length_mm-error")
        assert widget.display
        out = []
        for strip in widget.render_lines(widget.region.reset_offset):
            segments = list(strip)
            for f in app.get_line_filters():
                segments = f.apply(segments, widget.background_colors[1])
            for seg in segments:
                if seg.text.strip() and seg.style is not None and seg.style.color is not None:
                    out.append((contrast(seg.style.color.get_truecolor(), seg.style.bgcolor.get_truecolor()),
                                bool(seg.style.bold)))
        return out

    seen = run_form(check, source=source)
    assert seen and all(c >= 4.5 and bold for c, bold in seen), seen


def comment_lines(text: str) -> list[str]:
    """Every comment of a TOML text: whole comment lines and the comment part of value lines (found here
    by reading the text: a # outside a quoted string)."""
    out = []
    for line in text.splitlines():
        quoted = False
        for i, ch in enumerate(line):
            if ch == '"':
                quoted = not quoted
            elif ch == "#" and not quoted:
                out.append(line[i:].rstrip())
                break
    return out


@pytest.mark.parametrize(("name", "field", "typed", "table", "key", "value"), [
    ("setup-straightness.toml", "f-block-stations", "17", "block", "stations", 17),
    ("setup-positioning.toml", "f-axis-runs", "3", "axis", "runs", 3),
])
def test_ctrl_s_asks_before_overwriting_and_keeps_every_comment(tmp_path: Path, name: str, field: str, typed: str,
                                                                table: str, key: str, value: Any) -> None:
    original = (ROOT / "docs" / name).read_text()
    path = tmp_path / name
    path.write_text(original)

    async def check(pilot: Any, app: Any) -> tuple[str, str, str, str]:
        await type_into(pilot, app, field, typed)
        await pilot.press("ctrl+s")
        await wait_for_app(pilot, lambda: screen_name(app) == "ConfirmScreen", what="the overwrite question")
        asked = "\n".join(screen_lines(app))
        untouched = path.read_text()  # nothing written before the answer
        await pilot.press("y")
        await wait_for_app(pilot, lambda: "saved to" in str(app.screen.query_one("#file-note").render()),
                           what="the save")
        return asked, untouched, path.read_text(), "\n".join(screen_lines(app))

    asked, untouched, saved, shown = run_form(check, source=read_toml(path), setup_path=path)
    assert "Overwrite" in asked and untouched == original
    missing = [c for c in comment_lines(original) if c not in comment_lines(saved)]
    assert not missing, missing
    assert len(comment_lines(saved)) == len(comment_lines(original))
    assert read_toml(path)[table][key] == value
    # every other value as it was: the file read back equals the original with that one value changed
    expected = read_toml(ROOT / "docs" / name)
    expected[table][key] = value
    assert read_toml(path) == expected
    assert "give the set-up file name first" not in shown


def test_no_stale_file_message_after_a_successful_save(tmp_path: Path) -> None:
    path = tmp_path / "new.toml"

    async def check(pilot: Any, app: Any) -> tuple[str, str, str]:
        app.screen.query_one("#f-top-machine").focus()
        await pilot.press("ctrl+s")  # no file name yet
        await pilot.pause()
        first = "\n".join(screen_lines(app))
        await type_into(pilot, app, "setup-file", str(path))
        await pilot.press("ctrl+s")  # a new file: no question
        await wait_for_app(pilot, path.exists, what="the save")
        await pilot.pause()
        return first, "\n".join(screen_lines(app)), status(app)

    first, after, line = run_form(check, source=STRAIGHTNESS)
    assert "give the set-up file name first" in first
    assert "give the set-up file name first" not in after and "saved to" in after
    assert "set-up valid" in line
    assert read_toml(path)["block"] == STRAIGHTNESS["block"]


@pytest.mark.parametrize("where", ["setup", "runs"])
def test_ctrl_q_on_an_edited_form_asks_as_q_does_from_every_screen(where: str) -> None:
    """Ctrl+Q (Textual's own quit key) and q from another screen ask before losing the form's changes."""
    async def check(pilot: Any, app: Any) -> tuple[bool, str, str, bool]:
        await type_into(pilot, app, "f-block-stations", "12")
        app.screen.set_focus(None)
        if where == "runs":
            await pilot.press("f3")
            await wait_for_app(pilot, lambda: screen_name(app) == "RunsScreen", what="the runs screen")
        await pilot.press("ctrl+q")
        await pilot.pause()
        await wait_for_app(pilot, lambda: app._exit or screen_name(app) == "ConfirmScreen", what="the quit question")
        text = "\n".join(screen_lines(app))
        asked = screen_name(app)
        await pilot.press("n")
        await pilot.pause()
        kept = app._exit
        if where == "runs":  # q there is the application's quit: the same question
            await pilot.press("q")
            await wait_for_app(pilot, lambda: app._exit or screen_name(app) == "ConfirmScreen", what="the question")
            await pilot.press("y")
            await wait_for_app(pilot, lambda: app._exit, timeout_s=5, what="the app to quit")
        return kept, asked, text, app._exit

    kept, asked, text, _ = run_form(check)
    assert not kept and asked == "ConfirmScreen" and "not saved" in text

    async def untouched(pilot: Any, app: Any) -> bool:
        await pilot.press("ctrl+q")
        await wait_for_app(pilot, lambda: app._exit, timeout_s=5, what="the app to quit")
        return app._exit

    assert run_form(untouched)
