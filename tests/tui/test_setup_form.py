"""Set-up files written by the TUI read back to the same structure; loader messages map to fields."""

from __future__ import annotations

import tomllib
from pathlib import Path

import pytest

from acquisition.setup.files import setup_from_dict, setup_toml_text
from saved_runs.errors import SetupError
from saved_runs.toml_file import read_toml
from tui.screens.setup import field_for_message, positioning_fields, straightness_fields

DOCS = Path(__file__).resolve().parents[2] / "docs"


@pytest.mark.parametrize("name", ["setup-straightness.toml", "setup-positioning.toml"])
def test_written_setup_reads_back_equal(name: str) -> None:
    source = read_toml(DOCS / name)
    assert tomllib.loads(setup_toml_text(source)) == source
    setup_from_dict(tomllib.loads(setup_toml_text(source)))  # and the loader takes it


def test_a_string_with_quotes_and_a_nan_value() -> None:
    assert tomllib.loads(setup_toml_text({"notes": 'say "hi"\\n\tnext'}))["notes"] == 'say "hi"\\n\tnext'
    with pytest.raises(SetupError, match="nan"):
        setup_toml_text({"block": {"length_mm": float("nan")}})


def test_every_control_character_reads_back() -> None:
    # a carriage return (text pasted from Windows) or another control character in notes was written
    # as is, and TOML forbids it in a string: the saved set-up could not be read back
    text = "line 1\r\nline 2\x00\x1b[0m\x7f é µ \U0001F600"
    assert tomllib.loads(setup_toml_text({"notes": text, "machine": {"name": text}})) == {
        "notes": text, "machine": {"name": text}}


def _fields(groups):  # noqa: ANN001, ANN202
    return [f for _, g in groups for f in g]


@pytest.mark.parametrize(("data", "field"), [
    ({"block": {"length_mm": -1.0, "stations": 3}}, ("block", "length_mm")),
    ({"block": {"length_mm": 100.0, "stations": 1}}, ("block", "stations")),
    ({"block": {"length_mm": 100.0, "stations": 3}, "warmup": {"window": 1}}, ("warmup", "window")),
    ({"block": {"length_mm": 100.0, "stations": 3}, "validation": {"sensor_range_mm": [5.0, 1.0]}},
     ("validation", "sensor_range_mm")),
    ({"block": {"length_mm": 100.0, "stations": 3}, "controller": {"url": "tcp://x"}}, ("controller", "url")),
])
def test_loader_message_names_the_form_field(data: dict, field: tuple[str, str]) -> None:
    source = {"kind": "straightness", "geometry": {"mirror_mm": [50.0, 110.0, 0.0], "sensor_mm": [150.0, 0.0, 40.0]},
              **data}
    with pytest.raises(SetupError) as exc:
        setup_from_dict(source, "set-up")
    f = field_for_message(str(exc.value), _fields(straightness_fields(("keyence-lkg",))))
    assert f is not None and (f.table, f.key) == field


def test_positioning_message_names_the_runs_field() -> None:
    with pytest.raises(SetupError) as exc:
        setup_from_dict({"kind": "positioning", "axis": {"end_mm": 500.0, "runs": 0}}, "set-up")
    f = field_for_message(str(exc.value), _fields(positioning_fields("mm")))
    assert f is not None and (f.table, f.key) == ("axis", "runs")


@pytest.mark.parametrize(("data", "field"), [
    ({"environment": {"expansion_ppm_per_k": "x"}}, ("environment", "expansion_ppm_per_k")),
    ({"environment": {"abbe_offset_mm": [1.0, 2.0, 3.0]}}, ("environment", "abbe_offset_mm")),
    # 2.0 is no air index: refused when the set-up is checked, not after the run is captured
    ({"environment": {"refractive_index_assumed": 2.0}}, ("environment", "refractive_index_assumed")),
    ({"environment": {"index_equation": "lorentz"}}, ("environment", "index_equation")),
    ({"transmitter": {"url": "tcp://x"}}, ("transmitter", "url")),
])
def test_environment_messages_name_the_form_field(data: dict, field: tuple[str, str]) -> None:
    with pytest.raises(SetupError) as exc:
        setup_from_dict({"kind": "positioning", "axis": {"end_mm": 500.0, "runs": 5}, **data}, "set-up")
    f = field_for_message(str(exc.value), _fields(positioning_fields("mm")))
    assert f is not None and (f.table, f.key) == field


def test_rotary_form_has_no_air_compensation_fields() -> None:
    # an angle is not air-compensated (docs/positioning.md): no [environment] fields to mislead
    assert not [f for f in _fields(positioning_fields("deg")) if f.table in ("environment", "transmitter")]


def test_environment_fields_typed_into_the_form_are_saved_and_used(tmp_path: Path) -> None:
    import asyncio

    from textual.widgets import Input

    from tests.tui.sessions import POSITIONING
    from tests.waiting import wait_for_app
    from tui.app import GuidewayApp

    path = tmp_path / "aluminium.toml"

    async def main() -> None:
        app = GuidewayApp(setup_source=POSITIONING, start="setup", runs_dir=tmp_path, simulate=True)
        async with app.run_test(size=(160, 48)) as pilot:
            await wait_for_app(pilot, lambda: getattr(app.screen, "ready", False), what="the set-up form")
            app.screen.query_one("#setup-file", Input).value = str(path)
            app.screen.query_one("#f-environment-expansion_ppm_per_k", Input).value = "23.1"
            app.screen.query_one("#f-environment-abbe_offset_mm", Input).value = "12, -4"
            app.screen.query_one("#f-environment-index_equation").value = "edlen"
            await pilot.pause()
            assert app.screen.check(), app.screen.problem
            app.screen.query_one("#f-environment-refractive_index_assumed", Input).value = "2"
            await pilot.pause()
            assert not app.screen.check()
            error = app.screen.query_one("#f-environment-refractive_index_assumed-error")
            assert error.display and "is not an air index" in str(error.render())
            app.screen.query_one("#f-environment-refractive_index_assumed", Input).value = ""
            await pilot.pause()
            assert app.screen.check(), app.screen.problem
            app.screen.action_save()
            await pilot.pause()

    asyncio.run(main())
    env = setup_from_dict(read_toml(path)).environment
    assert (env.expansion_ppm_per_k, env.abbe_offset_mm, env.index_equation) == (23.1, (12.0, -4.0), "edlen")
    assert env.refractive_index_assumed == 1.0  # left blank: the loader's default
