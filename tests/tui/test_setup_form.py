"""Set-up files written by the TUI read back to the same structure; loader messages map to fields."""

from __future__ import annotations

import tomllib
from pathlib import Path

import pytest

from acquisition.errors import SetupError
from acquisition.setup import read_toml
from acquisition.setup_file import setup_from_dict, setup_toml_text
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
