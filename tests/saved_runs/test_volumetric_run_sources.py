"""Run directories as element sources: which run channel becomes which machine-frame component and
with which sign, for positioning runs (linear and rotary, imported) and a straightness run written
through the run store from first principles."""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
import pytest

from processing.volumetric.chain import element_values
from saved_runs.errors import SetupError
from saved_runs.importing.positioning import PositioningImport, import_positioning
from saved_runs.store.writer import RunStore
from saved_runs.volumetric.machine_file import machine_from_dict

ARCSEC_URAD = np.pi / 180 / 3600 * 1e6


def values(model, axis: str, q: float) -> dict[str, float]:  # noqa: ANN001
    pose = {a.name: np.asarray(a.reference) for a in model.axes}
    pose[axis] = np.asarray(q)
    return {e.id: float(element_values(e, pose, {})) for e in model.elements}


def machine(body: str, tmp: Path) -> object:
    return machine_from_dict(tomllib.loads('kind = "machine"\n' + body), "m.toml", base_dir=tmp).model


@pytest.fixture
def rotary_run(tmp_path: Path) -> Path:
    """A rotary axis: deviation +4 arcsec up and +2 arcsec down at 90 deg, 0 elsewhere."""
    rows = ["run,direction,target_deg,reading_deg"]
    for run in (1, 2):
        for direction, dev in ((1, 4.0), (-1, 2.0)):
            for t in (0.0, 90.0, 180.0, 270.0):
                rows.append(f"{run},{direction},{t},{t + (dev if t == 90.0 else 0.0) / 3600.0!r}")
    csv = tmp_path / "c.csv"
    csv.write_text("\n".join(rows) + "\n")
    import_positioning(csv, tmp_path / "c-pos", PositioningImport(axis_type="rotary", compensated=True))
    return tmp_path / "c-pos"


def test_rotary_positioning_run_gives_the_angular_error_in_urad(rotary_run: Path) -> None:
    body = ('[[workpiece_chain]]\nname = "C"\ntype = "rotary"\ndirection = "-Z"\nrange = [0.0, 270.0]\n'
            '[workpiece_chain.errors]\nEC = { run = "c-pos", channel = "linear" }\n'
            'EX = { run = "c-pos", channel = "linear", direction = "up" }\n')
    with pytest.raises(SetupError, match="measures EC of axis C"):  # an angle is not a displacement
        machine(body, rotary_run.parent)
    body = body.replace('EX = { run = "c-pos", channel = "linear", direction = "up" }', "")
    model = machine(body, rotary_run.parent)
    # the axis turns about -Z: an angle ahead of the command is a rotation about -Z, so EC = -deviation
    assert values(model, "C", 90.0)["ECC"] == pytest.approx(-3.0 * ARCSEC_URAD, abs=1e-6)  # mean of 4 and 2
    assert values(model, "C", 45.0)["ECC"] == pytest.approx(-1.5 * ARCSEC_URAD, abs=1e-6)
    up = machine(body.replace('channel = "linear" }', 'channel = "linear", direction = "up" }'), rotary_run.parent)
    assert values(up, "C", 90.0)["ECC"] == pytest.approx(-4.0 * ARCSEC_URAD, abs=1e-6)


@pytest.fixture
def y_run(tmp_path: Path) -> Path:
    """A linear positioning run of a vertical Y axis that also recorded straightness and angles."""
    rows = ["run,direction,target_mm,reading_mm,stry_um,strz_um,pitch_urad,yaw_urad,roll_urad"]
    for direction in (1, -1):
        for t in (0.0, 100.0, 200.0):
            k = t / 100.0
            rows.append(f"1,{direction},{t},{t + 0.001 * k},{1.0 * k},{2.0 * k},{3.0 * k},{4.0 * k},{5.0 * k}")
    csv = tmp_path / "y.csv"
    csv.write_text("\n".join(rows) + "\n")
    import_positioning(csv, tmp_path / "y-pos", PositioningImport(compensated=True))
    return tmp_path / "y-pos"


Y_AXIS = ('[[tool_chain]]\nname = "Y"\ntype = "prismatic"\ndirection = "+Y"\nrange = [0.0, 200.0]\n'
          '[tool_chain.errors]\n')


def test_run_frame_of_a_vertical_axis_maps_every_channel(y_run: Path) -> None:
    """Travel +Y, the run's 'up' along machine +Z: Z_r = Y × Z = +X.  So lin -> EY, stry -> EZ,
    strz -> EX, roll (about +Y) -> EB, yaw (about +Z) -> EC, pitch (about +X) -> EA."""
    src = '{{ run = "y-pos", channel = "{c}", up = "+Z" }}'
    body = Y_AXIS + "\n".join(f"{k} = {src.format(c=c)}" for k, c in
                              (("EY", "linear"), ("EZ", "stry"), ("EX", "strz"), ("EB", "roll"), ("EC", "yaw"),
                               ("EA", "pitch")))
    model = machine(body + "\n", y_run.parent)
    v = values(model, "Y", 200.0)
    assert v["EYY"] == pytest.approx(2.0, abs=1e-9)
    # straightness channels lose their least-squares line by default: here they are straight lines
    assert (v["EZY"], v["EXY"]) == pytest.approx((0.0, 0.0), abs=1e-9)
    assert (v["EBY"], v["ECY"], v["EAY"]) == pytest.approx((10.0, 8.0, 6.0), abs=1e-9)
    raw = machine(Y_AXIS + 'EX = { run = "y-pos", channel = "strz", up = "-Z", line = "none" }\n', y_run.parent)
    assert values(raw, "Y", 200.0)["EXY"] == pytest.approx(-4.0, abs=1e-9)  # up -Z: Z_r = Y × -Z = -X


def test_a_run_along_y_must_say_where_its_up_was(y_run: Path) -> None:
    with pytest.raises(SetupError, match="say which machine axis the run's Y"):
        machine(Y_AXIS + 'EZ = { run = "y-pos", channel = "stry" }\n', y_run.parent)
    # ... except for the linear channel, which lies along the travel whatever the up (docs/machine-example.toml)
    model = machine(Y_AXIS + 'EY = { run = "y-pos", channel = "linear" }\n', y_run.parent)
    assert values(model, "Y", 200.0)["EYY"] == pytest.approx(2.0, abs=1e-9)
    with pytest.raises(SetupError, match="channel stry of this run measures EZ of axis Y.*put it under EZ"):
        machine(Y_AXIS + 'EX = { run = "y-pos", channel = "stry", up = "+Z" }\n', y_run.parent)


def straightness_run(path: Path, heights_um: list[float], step_mm: float = 100.0) -> None:
    """A straightness run whose block never moves but along X, with a height-type sensor: the surface
    height profile is then the sensor reading itself (docs/conventions.md)."""
    geometry = {"mirror_mm": [50.0, 110.0, 0.0], "sensor_mm": [150.0, 0.0, 40.0], "sensor_beam": [0.0, -1.0, 0.0],
                "sensor_sign": "height"}
    store = RunStore(path, {"machine": "test", "axis": "X", "setup": {
        "block_length_mm": step_mm, "stations": len(heights_um), "geometry": geometry}})
    store("start", {"kind": "straightness", "uid": "t"})
    for k, h in enumerate(heights_um):
        store("event", {"data": {
            "station": k, "x_mm": k * step_mm, "time_s": float(k), "lin_um": 0.0, "stry_um": 0.0, "strz_um": 0.0,
            "pitch_urad": 0.0, "yaw_urad": 0.0, "roll_urad": 0.0, "sensor_mm": 1.0 + h * 1e-3, "air_temp_c": 20.0,
            "air_pressure_hpa": 1013.25, "humidity_pct": 50.0, "material_temp_c": 20.0, "pass": 0}})
    store("stop", {"exit_status": "success", "reason": "done"})


def test_straightness_run_travelling_backwards_from_a_start_position(tmp_path: Path) -> None:
    heights = [0.0, 3.0, 1.0, 4.0, 2.0]
    straightness_run(tmp_path / "str", heights)
    body = ('[[workpiece_chain]]\nname = "X"\ntype = "prismatic"\ndirection = "+X"\nrange = [0.0, 500.0]\n'
            '[workpiece_chain.errors]\n'
            'EY = { run = "str", channel = "straightness", travel = "-X", start = 450.0, line = "none" }\n')
    model = machine(body, tmp_path)
    for k, h in enumerate(heights):  # station k sits at 450 - 100 k
        assert values(model, "X", 450.0 - 100.0 * k)["EYX"] == pytest.approx(h, abs=1e-9)
    assert values(model, "X", 500.0)["EYX"] == pytest.approx(0.0, abs=1e-9)  # end value held beyond the data
    fitted = machine(body.replace(', line = "none"', ""), tmp_path)
    q = 450.0 - 100.0 * np.arange(5)
    line = np.polyval(np.polyfit(q, heights, 1), q)
    got = [values(fitted, "X", x)["EYX"] for x in q]
    np.testing.assert_allclose(got, np.array(heights) - line, atol=1e-9)
    with pytest.raises(SetupError, match="is a straightness run; the linear"):
        machine(body.replace('EY = { run = "str", channel = "straightness"', 'EX = { run = "str", channel = "linear"'),
                tmp_path)


@pytest.mark.parametrize(("option", "message"), [
    ('travel = "-Y"', "is a positioning run: its deviations are along the axis's own direction"),
    ("start = 50.0", "is a positioning run: its targets are axis positions already"),
])
def test_a_positioning_run_takes_no_straightness_run_placement(y_run: Path, option: str, message: str) -> None:
    """travel against the axis flipped the sign of the deviation, start shifted nothing: both are refused."""
    with pytest.raises(SetupError, match=message):
        machine(Y_AXIS + f'EY = {{ run = "y-pos", channel = "linear", up = "+Z", {option} }}\n', y_run.parent)
