"""Straightness set-up files: the documented example parses to the values it
shows, and every mistake is a one-line error naming the key."""

from __future__ import annotations

from pathlib import Path

import pytest

from acquisition.setup.stored import straightness_setup_from_run
from acquisition.setup.straightness import load_straightness_setup, straightness_setup_from_dict
from saved_runs.errors import SetupError

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "docs" / "setup-straightness.toml"


def minimal(**block) -> dict:
    return {"block": {"length_mm": 100.0, **block},
            "geometry": {"mirror_mm": [50, 110, 0], "sensor_mm": [150, 0, 40]}}


def test_documented_example_parses() -> None:
    s = load_straightness_setup(EXAMPLE)
    assert s.block_length_mm == 100.0 and s.stations == 20 and s.samples_per_reading == 5
    assert s.geometry.mirror_mm == (50.0, 110.0, 0.0) and s.geometry.sensor_sign == "height"
    assert s.devices.sensor_url == "/dev/ttyUSB0" and s.devices.controller_url.startswith("modbus-tcp://")
    assert s.warmup.enabled and s.warmup.window == 5 and s.validation.capture_attempts == 3
    assert not s.return_pass and s.machine == "Machine 7, bed"


@pytest.mark.parametrize(("travel", "length", "stations"), [(1900.0, 100.0, 20), (1000.0, 100.0, 11),
                                                              (1050.0, 100.0, 11), (123.0, 25.0, 5)])
def test_travel_length_gives_whole_steps_plus_datum(travel: float, length: float, stations: int) -> None:
    data = minimal(travel_length_mm=travel)
    data["block"]["length_mm"] = length
    assert straightness_setup_from_dict(data).stations == stations


@pytest.mark.parametrize(
    ("mutate", "message"),
    [
        (lambda d: d["block"].pop("length_mm"), "[block] length_mm is missing"),
        (lambda d: d["block"].update(stations=5, travel_length_mm=400.0), "exactly one of stations"),
        (lambda d: d.update(block={"length_mm": 100.0}), "exactly one of stations"),
        (lambda d: d["block"].update(samples_per_reading="five"), "samples_per_reading must be a whole number"),
        (lambda d: d["block"].update(stationz=3), "unknown key 'stationz' in [block]"),
        (lambda d: d.update(colour="red"), "unknown key 'colour' in top level"),
        (lambda d: d["geometry"].update(sensor_mm=[1, 2]), "sensor_mm must be a list of 3 numbers"),
        (lambda d: d["geometry"].update(sensor_beam=[0, -2, 0]), "unit vector"),
        (lambda d: d["geometry"].update(sensor_beam=[1, 0, 0]), "must point down at the surface"),
        (lambda d: d["geometry"].update(sensor_beam=[0.916515139, -0.4, 0]), "must point down at the surface"),
        (lambda d: d.update(controller={"word_order": "BADC"}), "word_order must be ABCD or CDAB"),
        (lambda d: d.update(warmup={"window": 1}), "window must be at least 2"),
        (lambda d: d.update(validation={"sensor_range_mm": [5, -5]}), "low < high"),
        (lambda d: d.update(uncertainty={"wobble_um": 1.0}), "unknown key 'wobble_um'"),
        (lambda d: d.update(kind="positioning"), "needs a straightness setup"),
        (lambda d: d["block"].update(return_pass="yes"), "return_pass must be a true/false"),
        (lambda d: d.update(sensor={"protocol": "laser-x"}), "protocol 'laser-x' is not supported"),
        (lambda d: d.update(controller={"url": "192.168.0.10:502"}), "must start with modbus-tcp://"),
        (lambda d: d["block"].update(length_mm=-1.0), "must be a positive length"),
        (lambda d: d["block"].update(stations=1), "stations must be at least 2"),
    ],
)
def test_setup_mistakes_are_one_line_errors(mutate, message: str) -> None:
    data = minimal(stations=5)
    mutate(data)
    with pytest.raises(SetupError) as info:
        straightness_setup_from_dict(data, "s.toml")
    assert message in str(info.value) and "\n" not in str(info.value)
    assert str(info.value).startswith("s.toml: ")  # which file to fix, whichever check refused


@pytest.mark.parametrize(("axis", "extra", "message"), [
    ({"runs": 0}, {}, "[axis] runs must be at least 1"),
    ({"overrun_mm": -1.0}, {}, "[axis] overrun_mm must be a positive distance"),
    ({"end_mm": -5.0}, {}, "end_mm > start_mm"),
    ({"targets_mm": [0.0, 10.0]}, {}, "[axis] targets"),
    ({}, {"trigger": {"dwell_s": -1.0}}, "[trigger] dwell_s must be a number >= 0"),
    ({"overrun_mm": 1.0}, {"trigger": {"mode": "stability"}}, "cannot follow this cycle"),
    ({}, {"environment": {"refractive_index_assumed": 2.0}}, "is not an air index"),
    ({"type": "rotary", "end_deg": 400.0}, {}, "0 < end_deg - start_deg <= 360"),
])
def test_positioning_refusals_name_the_setup_file(axis: dict, extra: dict, message: str) -> None:
    from acquisition.setup.positioning import positioning_setup_from_dict

    with pytest.raises(SetupError) as info:
        positioning_setup_from_dict({"kind": "positioning", "axis": {"end_mm": 500.0, **axis}, **extra}, "p.toml")
    text = str(info.value)
    assert text.startswith("p.toml: ") and message in text and "\n" not in text and "p.toml" not in text[8:]


def test_bad_files(tmp_path: Path) -> None:
    with pytest.raises(SetupError, match="no such setup file"):
        load_straightness_setup(tmp_path / "none.toml")
    (tmp_path / "bad.toml").write_text("[block\nlength_mm = 1")
    with pytest.raises(SetupError, match="not valid TOML"):
        load_straightness_setup(tmp_path / "bad.toml")


def test_run_json_setup_round_trip() -> None:
    s = load_straightness_setup(EXAMPLE)
    back = straightness_setup_from_run({**s.header(), "setup": s.to_run_setup()})
    assert back == s

