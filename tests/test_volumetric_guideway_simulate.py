"""A machine whose axes are ``guideway simulate`` runs recovers the errors put into their scenarios.

Three scenario files (docs/diagnosis.md), simulated without noise by the command line:

* ``x-pos``: an ISO 230-2 positioning run of the X table with a scale error, a screw-lead wave and
  backlash (effects), and the axis' pitch and yaw ([motion]) recorded with every point, in the
  scenario's air (raw counts: ``process`` compensates them);
* ``z-pos``: the Z head with an error table and a periodic error, and its pitch and yaw;
* ``x-str``: a gauge-block straightness run over a guideway whose surface is two waves and a slope.

The machine file takes X (workpiece chain): EXX = linear, EBX = yaw, ECX = pitch of ``x-pos``,
EYX = the profile of ``x-str``; Z (tool chain): EZZ = linear, EAZ = −pitch (a run along +Z with up
+Y has Z_r = Z × Y = −X), EBZ = yaw of ``z-pos``; and a squareness S_XZ.  The truth is written here
from the scenario numbers with the effect equations of docs/diagnosis.md (backlash ±B/2 averages
out of the ISO 230-2 mean x̄_i), and the volumetric error from rigid-body first order.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from processing.volumetric.chain import element_values
from saved_runs.volumetric.machine_file import load_machine
from tui.cli import main

from .controller_parsers import read_linuxcnc_comp
from .volumetric_xz import xz_first_order, xz_machine

X_TARGETS = [0.0, 48.0, 101.5, 149.0, 203.0, 251.0, 298.5, 352.0, 400.0]
Z_TARGETS = [0.0, 52.0, 98.0, 151.0, 203.0, 249.0, 300.0]

X_POS = f"""kind = "positioning"
[axis]
name = "X"
targets_mm = {X_TARGETS}
runs = 2
[trigger]
dwell_s = 1.0
[motion]
pitch_urad_per_m = 25.0
pitch_amplitude_urad = 6.0
pitch_wavelength_mm = 300.0
yaw_urad_per_m = -15.0
yaw_amplitude_urad = 4.0
yaw_wavelength_mm = 250.0
[[effect]]
type = "linear_scale"
ppm = 8.0
[[effect]]
type = "periodic"
amplitude_um = 1.5
wavelength_mm = 160.0
phase_rad = 0.0
[[effect]]
type = "backlash"
reversal_um = -2.0
"""

Z_POS = f"""kind = "positioning"
[axis]
name = "Z"
targets_mm = {Z_TARGETS}
runs = 2
[trigger]
dwell_s = 1.0
[motion]
pitch_urad_per_m = 10.0
pitch_amplitude_urad = 3.0
pitch_wavelength_mm = 200.0
yaw_amplitude_urad = 5.0
yaw_wavelength_mm = 150.0
[[effect]]
type = "error_table"
positions_mm = [0.0, 100.0, 200.0, 300.0]
error_um = [0.0, 1.2, -0.8, 0.5]
[[effect]]
type = "periodic"
amplitude_um = 0.7
wavelength_mm = 90.0
"""

X_STR = """kind = "straightness"
[block]
length_mm = 50.0
stations = 9
samples_per_reading = 1
return_pass = true
[geometry]
mirror_mm = [50.0, 110.0, 0.0]
sensor_mm = [150.0, 0.0, 40.0]
[surface]
waves = [[2.5, 380.0, 0.7], [0.6, 150.0, 2.0]]
slope_urad = 6.0
"""

MACHINE = xz_machine("X-Z machine from guideway simulate runs", """EX = { run = "x-pos", channel = "linear" }
EY = { run = "x-str", channel = "straightness" }
EB = { run = "x-pos", channel = "yaw" }
EC = { run = "x-pos", channel = "pitch" }
""", """EZ = { run = "z-pos", channel = "linear" }
EA = { run = "z-pos", channel = "pitch" }
EB = { run = "z-pos", channel = "yaw" }
""", extra='[frame]\nprimary = "X"\nsecondary = "Z"\n[[squareness]]\naxes = ["X", "Z"]\nvalue_urad = 15.0\n')
S_XZ = 15.0
SENSOR_X_MM = 150.0  # the sample point's place on the block: the first station samples the surface there


def wave(p: np.ndarray, amplitude: float, wavelength: float, phase: float = 0.0) -> np.ndarray:
    return amplitude * np.sin(2 * math.pi * p / wavelength + phase)


# The errors put in (um, urad; P in mm), from the scenarios above and docs/diagnosis.md's equations.
def lin_x(p: np.ndarray) -> np.ndarray:
    return 8.0 * p / 1000 + wave(p, 1.5, 160.0)  # linear_scale + periodic; backlash +-B/2 averages out


def pitch_x(p: np.ndarray) -> np.ndarray:
    return 25.0 * p / 1000 + wave(p, 6.0, 300.0)


def yaw_x(p: np.ndarray) -> np.ndarray:
    return -15.0 * p / 1000 + wave(p, 4.0, 250.0)


def lin_z(p: np.ndarray) -> np.ndarray:
    return np.interp(p, [0.0, 100.0, 200.0, 300.0], [0.0, 1.2, -0.8, 0.5]) + wave(p, 0.7, 90.0)


def pitch_z(p: np.ndarray) -> np.ndarray:
    return 10.0 * p / 1000 + wave(p, 3.0, 200.0)


def yaw_z(p: np.ndarray) -> np.ndarray:
    return wave(p, 5.0, 150.0)


def surface_um(x: np.ndarray) -> np.ndarray:
    """The scenario's guideway height at x along the guideway (mm)."""
    return 6.0e-3 * x + wave(x, 2.5, 380.0, 0.7) + wave(x, 0.6, 150.0, 2.0)


@pytest.fixture(scope="module")
def machine_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tmp_path_factory.mktemp("volumetric-simulate")
    for name, text in (("x-pos", X_POS), ("z-pos", Z_POS), ("x-str", X_STR)):
        (d / f"{name}.toml").write_text(text)
        assert main(["simulate", str(d / f"{name}.toml"), "--out", str(d / name), "--no-noise"]) == 0
    (d / "machine.toml").write_text(MACHINE)
    return d


def curve_of(model, element: str):  # noqa: ANN001, ANN201
    return next(e for e in model.elements if e.id == element)


def values_at(model, element: str, axis: str, q: np.ndarray) -> np.ndarray:  # noqa: ANN001
    return element_values(curve_of(model, element), {axis: np.asarray(q, dtype=float)}, {})


def profile_nodes(model) -> tuple[np.ndarray, np.ndarray]:  # noqa: ANN001
    """Where the straightness run sampled (axis positions, mm) and the truth there: the surface with its
    least-squares line over those points removed (the model's default, docs/volumetric.md)."""
    x = np.asarray(curve_of(model, "EYX").curve.positions, dtype=float)
    h = surface_um(SENSOR_X_MM + x)
    return x, h - np.polyval(np.polyfit(x, h, 1), x)


def test_every_element_is_the_error_put_into_the_scenarios(machine_dir: Path) -> None:
    model = load_machine(machine_dir / "machine.toml").model
    xt, zt = np.array(X_TARGETS), np.array(Z_TARGETS)
    np.testing.assert_allclose(values_at(model, "EXX", "X", xt), lin_x(xt), rtol=0, atol=1e-6)
    np.testing.assert_allclose(values_at(model, "ECX", "X", xt), pitch_x(xt), rtol=0, atol=1e-9)
    np.testing.assert_allclose(values_at(model, "EBX", "X", xt), yaw_x(xt), rtol=0, atol=1e-9)
    np.testing.assert_allclose(values_at(model, "EZZ", "Z", zt), lin_z(zt), rtol=0, atol=1e-6)
    np.testing.assert_allclose(values_at(model, "EAZ", "Z", zt), -pitch_z(zt), rtol=0, atol=1e-9)
    np.testing.assert_allclose(values_at(model, "EBZ", "Z", zt), yaw_z(zt), rtol=0, atol=1e-9)
    x, h = profile_nodes(model)
    np.testing.assert_allclose(x, 50.0 * np.arange(9), rtol=0, atol=0.01)  # the sample point of every station
    np.testing.assert_allclose(values_at(model, "EYX", "X", x), h, rtol=0, atol=1e-3)  # exact decoupling
    assert np.ptp(h) > 3.0 and np.ptp(lin_x(xt)) > 3.0 and np.ptp(pitch_x(xt)) > 10.0  # nothing trivially zero


def expected_error(model, x: float, z: float) -> np.ndarray:  # noqa: ANN001
    """Rigid-body first order (tests/volumetric_xz.py), the tool 80 mm below the Z carriage.  Each curve
    is the truth at the run's points, linear in between (ends held), as the model documents."""
    xt, zt = np.array(X_TARGETS), np.array(Z_TARGETS)
    xs, h = profile_nodes(model)

    def at(q: float, nodes: np.ndarray, truth: np.ndarray) -> float:
        return float(np.interp(q, nodes, truth))

    return xz_first_order(x, z, -80.0,
                          d_x=np.array([at(x, xt, lin_x(xt)), at(x, xs, h), 0.0]),
                          e_x=np.array([0.0, at(x, xt, yaw_x(xt)), at(x, xt, pitch_x(xt))]),
                          d_z=np.array([0.0, 0.0, at(z, zt, lin_z(zt))]),
                          e_z=np.array([-at(z, zt, pitch_z(zt)), at(z, zt, yaw_z(zt)), 0.0]), s_xz_urad=S_XZ)


def test_volumetric_error_over_the_targets_and_at_one_pose(machine_dir: Path,
                                                           capsys: pytest.CaptureFixture[str]) -> None:
    model = load_machine(machine_dir / "machine.toml").model
    out = machine_dir / "grid"
    assert main(["volumetric", str(machine_dir / "machine.toml"), "--out", str(out), "--grid", "5"]) == 0
    import pandas as pd

    table = pd.read_csv(out / "volumetric.csv")
    assert len(table) == 25
    for _, row in table.iterrows():
        np.testing.assert_allclose(row[["dx_um", "dy_um", "dz_um"]].to_numpy(float),
                                   expected_error(model, row["X_mm"], row["Z_mm"]), rtol=0, atol=2e-3)
    capsys.readouterr()
    for x, z in ((X_TARGETS[6], Z_TARGETS[4]), (X_TARGETS[-1], Z_TARGETS[-1])):
        assert main(["volumetric", str(machine_dir / "machine.toml"), "--at", f"X={x}", f"Z={z}", "--json",
                     "--exact"]) == 0
        obj = json.loads(capsys.readouterr().out)
        want = expected_error(model, x, z)
        e = obj["error"]
        np.testing.assert_allclose([e["dx_um"], e["dy_um"], e["dz_um"]], want, rtol=0, atol=2e-3)
        assert np.max(np.abs(want)) > 4.0
        rows = {r["element"]: r for r in obj["contributions"]}
        # the workpiece-chain table's own error enters the tool-relative error with the opposite sign
        assert rows["EXX"]["dx_um"] == pytest.approx(-lin_x(np.array(x)), abs=1e-6)
        assert rows["SXZ"]["dx_um"] == pytest.approx(-z * S_XZ * 1e-3, abs=1e-9)


def test_linuxcnc_tables_trim_the_axis_errors_put_in(machine_dir: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """LinuxCNC COMP_FILE_TYPE 1 holds trims, -e (docs/compensation.md): read back by the test-side reader,
    each table is minus the error along its axis at the tool point with the other axis at its reference 0
    (docs/volumetric.md): for X (workpiece chain: the tool relative to the workpiece moves the other way)
    the scenario's linear error plus the yaw's Abbe term at the tool 80 mm below the carriage; for Z
    (tool chain) the linear error, which no angle of Z moves along Z."""
    model = load_machine(machine_dir / "machine.toml").model
    out = machine_dir / "comp"
    assert main(["volumetric", str(machine_dir / "machine.toml"), "--export", "linuxcnc", "--out", str(out),
                 "--grid", "7"]) == 0
    for axis, targets in (("X", X_TARGETS), ("Z", Z_TARGETS)):
        comp = read_linuxcnc_comp((out / f"{axis}.comp").read_text(), file_type=1)
        assert comp.errors == [] and len(comp.nominal) == 7
        nominal = np.array(comp.nominal)
        np.testing.assert_allclose(nominal, np.linspace(targets[0], targets[-1], 7), atol=1e-6)
        if axis == "X":
            want = np.array([-expected_error(model, q, 0.0)[0] for q in nominal])
            xt = np.array(X_TARGETS)
            # the yaw turns the table about Y; the tool point, 80 mm below the carriage, sees (ε × r)_x = ε_y·(-80)
            abbe = -80.0 * np.interp(nominal, xt, yaw_x(xt)) * 1e-3
            np.testing.assert_allclose(want, np.interp(nominal, xt, lin_x(xt)) + abbe, atol=1e-9)
            assert np.max(np.abs(abbe)) > 0.5
        else:
            want = np.array([expected_error(model, 0.0, q)[2] for q in nominal])
            np.testing.assert_allclose(want, np.interp(nominal, targets, lin_z(np.array(targets))), atol=1e-9)
        for direction in (1, -1):
            np.testing.assert_allclose(comp.correction_um(nominal, direction), -want, atol=1.5e-3)  # 1 nm digits
