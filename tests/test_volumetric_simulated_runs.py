"""A machine whose axes are simulated runs recovers the errors that were put in.

The runs are made with the simulated rig behind its real transports: two ISO 230-2 positioning runs
by ``guideway acquire positioning --simulate --auto`` with an error curve chosen in the set-up's
[simulation] table (no noise, no thermal drift), and one straightness run of the simulated world
(``guideway demo`` path, noise off); tests/test_volumetric_guideway_simulate.py does the same with
``guideway simulate`` runs of scenario files.  The machine file takes

* axis X (workpiece chain): EXX from the X positioning run; EYX (the guideway profile), EAX
  (roll) and ECX (pitch) from the straightness run, run frame = machine frame;
* axis Z (tool chain): EZZ from the Z positioning run; EXZ, EAZ, EBZ from the same straightness
  run read as a run along +Z with up +Y, whose Z_r = Z × Y = −X: EXZ = −strz, EAZ = −pitch,
  EBZ = +yaw.

The truth comes from the simulators' own models: the axis error curve of the simulated machine
and the exact resting poses of the block in the simulated world (mocks.world), and the expected
volumetric error is written here from rigid-body kinematics.
"""

from __future__ import annotations

import io
import json
from pathlib import Path

import numpy as np
import pytest

from acquisition.demo import run_demo
from acquisition.setup.positioning import load_positioning_setup
from acquisition.simulated.machine import axis_errors
from mocks.world import euler_zyx
from processing.volumetric.evaluate import first_order
from saved_runs.volumetric.machine_file import load_machine
from tui.cli import main

from .cli import guideway
from .controller_parsers import read_linuxcnc_comp
from .volumetric_xz import xz_first_order, xz_machine

SETUP = """kind = "positioning"
machine = "simulated X-Z machine"
[axis]
name = "{name}"
type = "linear"
start_mm = 0.0
end_mm = {end}
runs = 1
[trigger]
mode = "in-position"
dwell_s = 0.0
[controller]
url = "modbus-tcp://127.0.0.1:502"
[simulation]
pitch_amplitude = {amp}
pitch_wavelength = {wl}
slope_per_m = {slope}
backlash = 2.0
periodic = {per}
periodic_period = 37.0
thermal_per_m_per_h = 0.0
noise = 0.0
"""

MACHINE = xz_machine("simulated X-Z machine", """EX = { run = "x-pos", channel = "linear" }
EY = { run = "str", channel = "straightness" }
EA = { run = "str", channel = "roll" }
EC = { run = "str", channel = "pitch" }
""", """EZ = { run = "z-pos", channel = "linear" }
EX = { run = "str", channel = "strz", line = "none" }
EA = { run = "str", channel = "pitch" }
EB = { run = "str", channel = "yaw" }
""")

STATIONS = 6


@pytest.fixture(scope="module")
def machine_dir(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict]:
    d = tmp_path_factory.mktemp("volumetric")
    truth: dict = {}
    for name, end, amp, wl, slope, per in (("X", 400.0, 3.0, 300.0, 10.0, 0.0), ("Z", 300.0, 2.0, 250.0, -8.0, 0.5)):
        setup = d / f"{name.lower()}.toml"
        setup.write_text(SETUP.format(name=name, end=end, amp=amp, wl=wl, slope=slope, per=per))
        out = d / f"{name.lower()}-pos"
        assert main(["acquire", "positioning", "--setup", str(setup), "--out", str(out), "--simulate", "--auto"]) == 0
        errors = axis_errors(load_positioning_setup(setup), noise=False)  # what the simulated axis does
        truth[name] = lambda p, e=errors: (e.deviation(p, 1, 0.0) + e.deviation(p, -1, 0.0)) / 2  # mean of both
        truth[f"{name}_targets"] = np.array(json.loads((out / "run.json").read_text())["setup"]["targets_mm"])
    demo = run_demo(d / "str", stations=STATIONS, seed=4, noise=False, stream=io.StringIO())
    world = demo.sim.world
    poses = [world.solve_pose(world.nominal_x_mm(k)) for k in range(STATIONS)]
    r0 = poses[0].r
    laser = world.in_laser_frame  # the interferometer reports in the laser's fixed frame (docs/conventions.md)
    hits = [world.beam_hit(p)[1] for p in poses]
    s = np.array([laser(h - hits[0]) for h in hits])  # sample points in the laser frame (mm)
    mirror = np.asarray(world.block.mirror_mm)
    p_moves = np.array([laser(p.apply(mirror) - poses[0].apply(mirror)) for p in poses])
    # rotation since the datum, in the laser frame: L^T (R_k R_0^T) L; roll, yaw, pitch (urad)
    angles = np.array([euler_zyx(laser(laser(p.r @ r0.T).T).T) for p in poses]) * 1e6
    height = s[:, 1] * 1e3
    height = height - np.polyval(np.polyfit(s[:, 0], height, 1), s[:, 0])  # least-squares line removed
    truth["profile"] = (s[:, 0], height)
    truth["x_nominal"] = np.array([world.nominal_x_mm(k) for k in range(STATIONS)])
    truth["roll"], truth["yaw"], truth["pitch"] = angles[:, 0], angles[:, 1], angles[:, 2]
    truth["strz"] = p_moves[:, 2] * 1e3
    (d / "machine.toml").write_text(MACHINE)
    return d, truth


def element_values(model, pose: dict[str, float]) -> dict[str, float]:  # noqa: ANN001
    from processing.volumetric.chain import element_values as values

    return {e.id: float(values(e, {k: np.asarray(v) for k, v in pose.items()}, {})) for e in model.elements}


def test_every_element_is_the_error_put_in(machine_dir: tuple[Path, dict]) -> None:
    d, truth = machine_dir
    mf = load_machine(d / "machine.toml")
    run = json.loads((d / "x-pos" / "run.json").read_text())
    for x in run["setup"]["targets_mm"]:
        assert element_values(mf.model, {"X": x, "Z": 0.0})["EXX"] == pytest.approx(truth["X"](x), abs=1e-4)
    run = json.loads((d / "z-pos" / "run.json").read_text())
    for z in run["setup"]["targets_mm"]:
        assert element_values(mf.model, {"X": 0.0, "Z": z})["EZZ"] == pytest.approx(truth["Z"](z), abs=1e-4)
    xs, h = truth["profile"]
    for k in range(STATIONS):
        if xs[k] <= 400.0:
            assert element_values(mf.model, {"X": xs[k], "Z": 0.0})["EYX"] == pytest.approx(h[k], abs=0.02)
        x = truth["x_nominal"][k]
        vx = element_values(mf.model, {"X": min(x, 400.0), "Z": min(x, 300.0)})
        if x <= 400.0:
            assert vx["EAX"] == pytest.approx(truth["roll"][k], abs=1e-3)
            assert vx["ECX"] == pytest.approx(truth["pitch"][k], abs=1e-3)
        if x <= 300.0:  # the same run read along +Z, up +Y: Z_r = -X
            assert vx["EXZ"] == pytest.approx(-truth["strz"][k], abs=1e-3)
            assert vx["EAZ"] == pytest.approx(-truth["pitch"][k], abs=1e-3)
            assert vx["EBZ"] == pytest.approx(truth["yaw"][k], abs=1e-3)
    assert np.ptp(truth["pitch"]) > 10 and np.ptp(truth["strz"]) > 0.5  # the curves are not trivially zero


def expected_error(truth: dict, x: float, z: float) -> np.ndarray:
    """Rigid-body first order (tests/volumetric_xz.py), the tool 80 mm below the Z carriage.  Every error
    curve is the truth at the measured points, linear in between (ends held), as the model documents."""
    xs, h = truth["profile"]
    xn = truth["x_nominal"]

    def curve(values: np.ndarray, q: float, nodes: np.ndarray = xn) -> float:
        return float(np.interp(q, nodes, values))

    def positioning(axis: str, q: float) -> float:
        nodes = truth[f"{axis}_targets"]
        return curve(np.array([truth[axis](p) for p in nodes]), q, nodes)

    return xz_first_order(x, z, -80.0,
                          d_x=np.array([positioning("X", x), curve(h, x, xs), 0.0]),
                          e_x=np.array([curve(truth["roll"], x), 0.0, curve(truth["pitch"], x)]),
                          d_z=np.array([-curve(truth["strz"], z), 0.0, positioning("Z", z)]),
                          e_z=np.array([-curve(truth["pitch"], z), curve(truth["yaw"], z), 0.0]))


def test_volumetric_error_at_the_positioning_targets(machine_dir: tuple[Path, dict]) -> None:
    """At the targets the positioning curves are data points; the straightness curves are
    interpolated linearly between stations as the model documents, so the expectation is too."""
    d, truth = machine_dir
    mf = load_machine(d / "machine.toml")
    xt = json.loads((d / "x-pos" / "run.json").read_text())["setup"]["targets_mm"]
    zt = json.loads((d / "z-pos" / "run.json").read_text())["setup"]["targets_mm"]
    gx, gz = np.meshgrid(xt, zt, indexing="ij")
    got = first_order(mf.model, {"X": gx.ravel(), "Z": gz.ravel()}, mf.conditions).position_um
    want = np.array([expected_error(truth, x, z) for x, z in zip(gx.ravel(), gz.ravel(), strict=True)])
    np.testing.assert_allclose(got, want, rtol=0, atol=0.02)
    assert np.max(np.abs(want)) > 5.0


def test_cli_at_json_names_the_dominant_elements(machine_dir: tuple[Path, dict]) -> None:
    d, truth = machine_dir
    code, out, err = guideway("volumetric", str(d / "machine.toml"), "--at", "250", "150", "--json")
    assert code == 0, err
    obj = json.loads(out)
    assert obj["pose"] == {"X": 250.0, "Z": 150.0} and obj["method"] == "first-order"
    e = obj["error"]
    np.testing.assert_allclose([e["dx_um"], e["dy_um"], e["dz_um"]], expected_error(truth, 250.0, 150.0), atol=0.02)
    rows = {r["element"]: r for r in obj["contributions"]}
    assert len(rows) == 12 and obj["dominant"][0] == obj["contributions"][0]["element"]
    assert [r["d_um"] for r in obj["contributions"]] == sorted((r["d_um"] for r in obj["contributions"]), reverse=True)
    total = sum(np.array([r["dx_um"], r["dy_um"], r["dz_um"]]) for r in obj["contributions"])
    np.testing.assert_allclose(total, [e["dx_um"], e["dy_um"], e["dz_um"]], atol=1e-9)
    assert rows["EXX"]["value"] == pytest.approx(np.interp(250.0, truth["X_targets"], [truth["X"](p) for p in
                                                                                       truth["X_targets"]]), abs=1e-4)
    assert rows["EXX"]["dx_um"] == -rows["EXX"]["value"]  # a workpiece-chain translation: minus
    assert rows["EZZ"]["dz_um"] == rows["EZZ"]["value"]


def test_cli_grid_writes_csv_summary_and_report(machine_dir: tuple[Path, dict], tmp_path: Path) -> None:
    d, truth = machine_dir
    out = tmp_path / "grid"
    code, _, err = guideway("volumetric", str(d / "machine.toml"), "--out", str(out), "--grid", "5", "--exact")
    assert code == 0, err
    import pandas as pd

    table = pd.read_csv(out / "volumetric.csv")
    assert list(table.columns) == ["X_mm", "Z_mm", "dx_um", "dy_um", "dz_um", "d_um", "ex_urad", "ey_urad",
                                   "ez_urad"]
    assert len(table) == 25 and sorted(set(table["X_mm"])) == [0.0, 100.0, 200.0, 300.0, 400.0]
    row = table[(table["X_mm"] == 200.0) & (table["Z_mm"] == 150.0)].iloc[0]
    np.testing.assert_allclose(row[["dx_um", "dy_um", "dz_um"]].to_numpy(float), expected_error(truth, 200.0, 150.0),
                               atol=0.02)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["method"] == "exact" and summary["elements"]["total"] == 12
    assert summary["max_distance_um"]["value"] == pytest.approx(table["d_um"].max(), abs=1e-5)
    assert 0 <= summary["exact_minus_first_order_um"] < 1e-3
    contrib = pd.read_csv(out / "contributions.csv")
    groups = sum(contrib[f"{g}_{c}"] for g in ("X", "Z") for c in ("dx_um",))
    fo = first_order(load_machine(d / "machine.toml").model,
                     {"X": contrib["X_mm"].to_numpy(), "Z": contrib["Z_mm"].to_numpy()}, {}).position_um
    np.testing.assert_allclose(groups, fo[:, 0], atol=1e-5)
    html = (out / "report.html").read_text()
    assert html.count("<img") >= 2 and "XZ plane" in html and "EXX" in html


def test_cli_export_linuxcnc_tables_read_back(machine_dir: tuple[Path, dict], tmp_path: Path) -> None:
    """The X table holds EXX (Z at its reference 0: no cross term along X there), the Z table EZZ;
    read back as LinuxCNC does, the correction is -error."""
    d, truth = machine_dir
    out = tmp_path / "comp"
    code, stdout, err = guideway("volumetric", str(d / "machine.toml"), "--export", "linuxcnc", "--out",
                                 str(out), "--grid", "9")
    assert code == 0, err
    assert "cross terms" in stdout
    for axis in ("X", "Z"):
        comp = read_linuxcnc_comp((out / f"{axis}.comp").read_text(), file_type=1)
        nodes = truth[f"{axis}_targets"]  # the model: linear between the targets, ends held
        assert comp.errors == [] and len(comp.nominal) == 9
        # no table reaches outside the measured range: first to last target
        np.testing.assert_allclose(comp.nominal, np.linspace(nodes[0], nodes[-1], 9), atol=1e-6)
        expected = np.interp(comp.nominal, nodes, [truth[axis](p) for p in nodes])
        for direction in (1, -1):
            np.testing.assert_allclose(comp.correction_um(np.array(comp.nominal), direction), -expected,
                                       atol=1.5e-3)  # 1 nm digits
    cross = (out / "cross-terms.csv").read_text().splitlines()
    assert cross[0].startswith("element,group,body,target,max_abs,unit,X_mm,Z_mm,source")
    assert any(line.startswith("EYX,") for line in cross[1:])  # X's straightness: along Y, no Y axis to hold it
