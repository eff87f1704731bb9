"""The volumetric model (processing/volumetric) against independent references:

* seed 000's closed form for X–Z motion with B = C = 0, with its symbols mapped onto our elements,
  and seed 000's own matrices (eq. 8, 10, 12) multiplied out in the test;
* the exact evaluation against explicit 4×4 products (tests/processing/volumetric_reference.py);
* the first-order evaluation as the linear part of that product (central differences), and where
  first order and exact part.
"""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest

from processing.volumetric.curves import Polynomial
from processing.volumetric.evaluate import contributions, exact, first_order
from processing.volumetric.model import COMPONENTS, Body, MachineModel, component_element, squareness_element
from saved_runs.volumetric.machine_file import machine_from_dict

from .volumetric_reference import Reference

# -- seed 000: the X-Z polishing platform ----------------------------------------------------------
# Seed symbol -> our element (docs/volumetric.md, "Seed 000").  Seed 000 measures translation errors
# positive along the axes and angles by the right-hand rule, as we do, and names them by the axis
# they are about: for X, eps_xX roll, eps_yX yaw, eps_zX pitch; for Z, eps_xZ pitch, eps_yZ yaw,
# eps_zZ roll.  Its X slide carries the workpiece (workpiece chain), its Z slide the tool.
SEED000 = {"dxX": "EXX", "dyX": "EYX", "dzX": "EZX", "exX": "EAX", "eyX": "EBX", "ezX": "ECX",
           "dxZ": "EXZ", "dyZ": "EYZ", "dzZ": "EZZ", "exZ": "EAZ", "eyZ": "EBZ", "ezZ": "ECZ"}


def seed000_model(rng: np.random.Generator, s_xz: float) -> MachineModel:
    x = Body("X", "prismatic", "workpiece", 0, 1.0, range=(0.0, 200.0))
    z = Body("Z", "prismatic", "tool", 2, 1.0, range=(0.0, 200.0))
    elements = []
    for b in (x, z):
        for c in COMPONENTS:  # a smooth random curve per element: um or urad
            coeffs = tuple(rng.normal(0.0, 1.0, 3) * (3.0, 0.02, 1e-4))
            elements.append(component_element(b, c, "motion", Polynomial(coeffs), "position"))
    elements.append(squareness_element((x, z), ("X", "Z"), s_xz, "X", "Z"))  # seed 000: X is the reference
    return MachineModel((x,), (z,), tuple(elements), primary="X", secondary="Z")


def test_first_order_is_seed000_closed_form_for_x_z_motion() -> None:
    rng = np.random.default_rng(0)
    s_xz = 17.0  # urad
    model = seed000_model(rng, s_xz)
    x = rng.uniform(0.0, 200.0, 25)
    z = rng.uniform(0.0, 200.0, 25)
    curves = {e.id: e.curve for e in model.elements}
    v = {sym: curves[el](x if el.endswith("X") else z) for sym, el in SEED000.items()}
    um = 1e-3  # urad * mm = 1e-3 um
    # seed 000, X-Z motion with B = C = 0 (position: um, orientation: urad)
    dx = v["dxZ"] - z * v["eyX"] * um - z * s_xz * um - v["dxX"]
    dy = v["dyZ"] + z * v["exX"] * um + x * v["ezX"] * um - v["dyX"]
    dz = v["dzZ"] - x * v["eyX"] * um - v["dzX"]  # the seed prints +dzX: see the next test
    fo = first_order(model, {"X": x, "Z": z}, {})
    np.testing.assert_allclose(fo.position_um, np.stack((dx, dy, dz), axis=-1), rtol=0, atol=1e-12)
    orientation = np.stack((-v["exX"] + v["exZ"], v["eyZ"] - v["eyX"], -v["ezX"] + v["ezZ"]), axis=-1)
    np.testing.assert_allclose(fo.orientation_urad, orientation, rtol=0, atol=1e-12)


def seed000_matrix(d: tuple[float, float, float], e: tuple[float, float, float]) -> np.ndarray:
    """Seed 000 eq. 8 / 10: the first-order error matrix of a pair (translations mm, angles rad)."""
    ex, ey, ez = e
    return np.array([[1, -ez, ey, d[0]], [ez, 1, -ex, d[1]], [-ey, ex, 1, d[2]], [0, 0, 0, 1.0]])


def test_seed000_matrices_give_minus_dzX_so_the_printed_plus_sign_is_a_misprint() -> None:
    """Seed 000 eq. 12 with B = C = 0: T37 = (T01 dT01)^-1 T04 dT04; dE = T37 - T37,i (eq. 13)."""
    rng = np.random.default_rng(1)
    s_xz = 9.0
    model = seed000_model(rng, s_xz)
    curves = {e.id: e.curve for e in model.elements}
    for x, z in ((40.0, 170.0), (190.0, 20.0), (120.0, 120.0)):
        v = {sym: float(curves[el](x if el.endswith("X") else z)) for sym, el in SEED000.items()}
        t01 = np.eye(4)
        t01[0, 3] = x
        t04 = np.eye(4)
        t04[2, 3] = z
        dt01 = seed000_matrix((v["dxX"] * 1e-3, v["dyX"] * 1e-3, v["dzX"] * 1e-3),
                              (v["exX"] * 1e-6, v["eyX"] * 1e-6, v["ezX"] * 1e-6))
        dt04 = seed000_matrix((v["dxZ"] * 1e-3 - z * s_xz * 1e-6, v["dyZ"] * 1e-3, v["dzZ"] * 1e-3),
                              (v["exZ"] * 1e-6, v["eyZ"] * 1e-6, v["ezZ"] * 1e-6))
        t37 = np.linalg.inv(t01 @ dt01) @ t04 @ dt04
        t37_ideal = np.linalg.inv(t01) @ t04
        d_seed = (t37 - t37_ideal)[:3, 3] * 1e3  # um, second order in the errors aside
        fo = first_order(model, {"X": x, "Z": z}, {}).position_um
        np.testing.assert_allclose(fo, d_seed, rtol=0, atol=2e-4)  # second-order terms: < 0.2 nm here
        printed = v["dzZ"] - x * v["eyX"] * 1e-3 + v["dzX"]  # seed 000 as printed
        assert abs(d_seed[2] - printed) == pytest.approx(2 * abs(v["dzX"]), abs=2e-4)


# -- a five-axis machine with every kind of element, as a machine file -----------------------------
MACHINE = """
kind = "machine"
name = "test 5-axis"
[frame]
primary = "X"
secondary = "Y"
[conditions]
temperature_c = 23.0
time_h = 1.5
[tool]
offset_mm = [10.0, -5.0, -160.0]
[[workpiece_chain]]
name = "Y"
type = "prismatic"
direction = "+Y"
range = [0.0, 600.0]
[workpiece_chain.errors]
EX = { poly = [0.5, 0.004, -3e-6] }
EY = { positions = [0.0, 200.0, 400.0, 600.0], values = [0.0, 2.0, -1.0, 3.0] }
EZ = { poly = [0.0, 0.0, 5e-6], origin = 300.0 }
EA = { poly = [2.0, 0.02] }
EB = { poly = [-1.0, 0.01] }
EC = { poly = [0.0, -0.03] }
[[workpiece_chain]]
name = "C"
type = "rotary"
direction = "+Z"
offset_mm = [250.0, 300.0, 50.0]
range = [0.0, 360.0]
[workpiece_chain.errors]
EX = { poly = [0.0, 0.01] }
EY = { poly = [1.0, -0.005] }
EZ = 0.7
EA = { poly = [0.0, 0.04] }
EB = { poly = [3.0, -0.02] }
EC = { positions = [0.0, 120.0, 240.0, 360.0], values = [0.0, 9.0, -4.0, 0.0] }
[workpiece_chain.location]
EX = 4.0
EY = -3.0
EZ = 2.0
EA = 14.0
EB = -9.0
EC = 6.0
[workpiece_chain.thermal]
EZ = { of = "temperature_c", poly = [0.0, 1.3], origin = 20.0 }
[[tool_chain]]
name = "X"
type = "prismatic"
direction = "-X"
offset_mm = [0.0, 0.0, 300.0]
range = [-100.0, 500.0]
[tool_chain.errors]
EX = { poly = [0.0, 0.006] }
EY = { poly = [0.3, 0.0, 4e-6] }
EZ = { poly = [0.0, -0.002] }
EA = { poly = [0.0, 0.015] }
EB = { poly = [1.5, 0.01] }
EC = { poly = [0.0, 0.02] }
[[tool_chain]]
name = "Z"
type = "prismatic"
direction = "+Z"
range = [-300.0, 100.0]
[tool_chain.errors]
EX = { poly = [0.0, 0.0, 6e-6] }
EY = { poly = [0.0, 0.003] }
EZ = { poly = [0.0, -0.005] }
EA = { poly = [1.0, 0.012] }
EB = { poly = [0.0, -0.02] }
EC = 2.5
[[tool_chain]]
name = "A"
type = "rotary"
direction = "+X"
offset_mm = [0.0, 20.0, -100.0]
range = [-90.0, 90.0]
[tool_chain.errors]
EX = 0.5
EY = { poly = [0.0, 0.02] }
EZ = { poly = [0.0, -0.01] }
EA = { poly = [0.0, 0.06] }
EB = { poly = [0.0, 0.0, 5e-4] }
EC = { poly = [0.0, -0.03] }
[tool_chain.location]
EX = -6.0
EY = 5.0
EA = 8.0
EC = -7.0
[[tool_chain]]
name = "S"
type = "fixed"
offset_mm = [0.0, 0.0, -40.0]
[tool_chain.location]
EZ = 3.0
EB = 4.0
[tool_chain.thermal]
EZ = { of = "time_h", positions = [0.0, 1.0, 2.0], values = [0.0, 10.0, 14.0] }
EA = { of = "time_h", poly = [0.0, 3.0] }
EB = { of = "temperature_c", poly = [0.0, -2.0], origin = 20.0 }
[[squareness]]
axes = ["X", "Y"]
value_urad = -27.0
[[squareness]]
axes = ["Z", "X"]
value_urad = 14.0
[[squareness]]
axes = ["Y", "Z"]
value_urad = -9.0
"""


@pytest.fixture(scope="module")
def five_axis() -> tuple[dict, MachineModel, dict]:
    data = tomllib.loads(MACHINE)
    mf = machine_from_dict(data, "test.toml")
    return data, mf.model, mf.conditions


def poses(n: int, seed: int = 3) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    return {"Y": rng.uniform(0, 600, n), "C": rng.uniform(0, 360, n), "X": rng.uniform(-100, 500, n),
            "Z": rng.uniform(-300, 100, n), "A": rng.uniform(-90, 90, n)}


def test_exact_evaluation_is_the_product_of_the_4x4_matrices(five_axis) -> None:  # noqa: ANN001
    data, model, cond = five_axis
    p = poses(12)
    got = exact(model, p, cond)
    ref = Reference(data)
    for i in range(12):
        d, e = ref.error({k: float(v[i]) for k, v in p.items()})
        np.testing.assert_allclose(got.position_um[i], d, rtol=0, atol=1e-7)
        np.testing.assert_allclose(got.orientation_urad[i], e, rtol=0, atol=1e-7)


def test_first_order_is_the_linear_part_of_the_4x4_product(five_axis) -> None:  # noqa: ANN001
    data, model, cond = five_axis
    p = poses(8, seed=5)
    fo = first_order(model, p, cond)
    ref = Reference(data)
    lam = 1e-3  # central difference in the scale of every element: the linear term, O(lam^2) left
    for i in range(8):
        pose = {k: float(v[i]) for k, v in p.items()}
        dp, ep = ref.error(pose, scale=lam)
        dm, em = ref.error(pose, scale=-lam)
        np.testing.assert_allclose(fo.position_um[i], (dp - dm) / (2 * lam), rtol=0, atol=1e-6)
        np.testing.assert_allclose(fo.orientation_urad[i], (ep - em) / (2 * lam), rtol=0, atol=1e-6)


def test_contributions_add_up_to_the_first_order_error(five_axis) -> None:  # noqa: ANN001
    _, model, cond = five_axis
    p = poses(30, seed=7)
    fo = first_order(model, p, cond)
    d = sum(c[1] for c in contributions(model, p, cond))
    w = sum(c[2] for c in contributions(model, p, cond))
    np.testing.assert_allclose(d, fo.position_um, rtol=0, atol=1e-9)
    np.testing.assert_allclose(w, fo.orientation_urad, rtol=0, atol=1e-9)
    # motion 5 x 6, location C 6 + A 4 + S 2, squareness 3, thermal C 1 + S 3
    assert len(list(contributions(model, p, cond))) == model.counts()["total"] == 30 + 12 + 3 + 4


def test_first_and_exact_agree_to_second_order_and_part_at_large_errors(five_axis) -> None:  # noqa: ANN001
    data, model, cond = five_axis
    ref = Reference(data)
    pose = {k: float(v[0]) for k, v in poses(1, seed=11).items()}
    fo = first_order(model, {k: np.asarray(v) for k, v in pose.items()}, cond).position_um
    gaps = []
    for lam in (0.5, 1.0, 2.0, 4.0):
        d, _ = ref.error(pose, scale=lam)
        gaps.append(np.linalg.norm(d - lam * fo))
    ratios = [gaps[i + 1] / gaps[i] for i in range(3)]
    assert ratios == pytest.approx([4.0, 4.0, 4.0], rel=0.05)  # the gap is quadratic in the errors
    assert gaps[1] < 1e-3  # at the file's errors (tens of urad): below a nanometre


def test_a_large_yaw_parts_first_order_from_exact_by_z_eps2_over_2() -> None:
    """One yaw error EBX = 2 mrad with the tool 500 mm away along Z: exact rotation moves the tool
    point by z·sin ε along X and z·(1 − cos ε) along Z; first order gives z·ε and nothing along Z."""
    eps = 2000.0  # urad
    x = Body("X", "prismatic", "tool", 0, 1.0, range=(0.0, 100.0))
    model = MachineModel((), (x,), (component_element(x, "EB", "motion", Polynomial((eps,)), "position"),),
                         tool_offset_mm=(0.0, 0.0, 500.0))
    p = {"X": np.asarray(50.0)}
    fo, ex = first_order(model, p, {}).position_um, exact(model, p, {}).position_um
    e = eps * 1e-6
    assert fo == pytest.approx([500e3 * e, 0.0, 0.0], abs=1e-9)
    assert ex == pytest.approx([500e3 * math.sin(e), 0.0, -500e3 * (1 - math.cos(e))], abs=1e-9)
    assert abs(ex[2] - fo[2]) == pytest.approx(500e3 * e * e / 2, rel=1e-5)  # 1 um: first order misses it


def test_squareness_is_the_angle_between_the_actual_axes_minus_90_degrees() -> None:
    """Move each axis alone and recover its actual direction from the exact error: a tool-chain
    axis moves the tool by q·u', a workpiece-chain axis moves the workpiece (the tool by −q·u')."""
    xs = Body("X", "prismatic", "tool", 0, 1.0, range=(0.0, 100.0))
    ys = Body("Y", "prismatic", "workpiece", 1, -1.0, range=(0.0, 100.0))  # a table moving along -Y
    zs = Body("Z", "prismatic", "tool", 2, 1.0, offset_mm=(5.0, 0.0, 0.0), range=(0.0, 100.0))
    bodies = (ys, xs, zs)
    s = {("X", "Y"): 300.0, ("X", "Z"): -200.0, ("Z", "Y"): 150.0}  # urad; large to see them plainly
    els = tuple(squareness_element(bodies, pair, v, "X", "Y") for pair, v in s.items())
    model = MachineModel((ys,), (xs, zs), els, primary="X", secondary="Y")
    zero = {"X": np.asarray(0.0), "Y": np.asarray(0.0), "Z": np.asarray(0.0)}

    def direction(axis: str) -> np.ndarray:
        body = model.body(axis)
        change = (exact(model, {**zero, axis: np.asarray(100.0)}, {}).position_um
                  - exact(model, zero, {}).position_um) * 1e-3 / 100.0
        u = body.direction + (-1.0 if body.chain == "workpiece" else 1.0) * change
        return u / np.linalg.norm(u)

    u = {a: direction(a) for a in "XYZ"}
    assert np.array_equal(u["X"], [1.0, 0.0, 0.0])  # the primary axis defines its direction
    assert u["Y"][2] == 0.0  # the secondary lies in the plane of the two
    for (a, b), value in s.items():
        obtuse_by = math.acos(float(u[a] @ u[b])) - math.pi / 2
        assert obtuse_by * 1e6 == pytest.approx(value, rel=2e-3)


def test_machine_frame_is_the_workpiece_frame_turned_by_the_table(five_axis) -> None:  # noqa: ANN001
    """With the rotary table C in the workpiece chain the two frames differ by the table's rotation.
    First order is linear, so its orientation (a small rotation vector) turns like a vector."""
    _, model, cond = five_axis
    p = poses(10, seed=13)
    for evaluate in (first_order, exact):
        wp, mc = evaluate(model, p, cond, "workpiece"), evaluate(model, p, cond, "machine")
        c = np.deg2rad(p["C"])
        turn = np.array([[np.cos(c), -np.sin(c), 0 * c], [np.sin(c), np.cos(c), 0 * c], [0 * c, 0 * c, 1 + 0 * c]])
        turn = np.moveaxis(turn, -1, 0)  # Rz(C) per pose: the nominal workpiece frame in the machine frame
        np.testing.assert_allclose(mc.position_um, np.einsum("nij,nj->ni", turn, wp.position_um), atol=1e-9)
        tolerance = 1e-9 if evaluate is first_order else 1e-2  # exact: equal to first order only (next test)
        np.testing.assert_allclose(mc.orientation_urad, np.einsum("nij,nj->ni", turn, wp.orientation_urad),
                                   atol=tolerance)
        assert np.max(np.abs(mc.position_um - wp.position_um)) > 1.0


def test_exact_machine_frame_orientation_is_the_angles_of_the_turned_matrix(five_axis) -> None:  # noqa: ANN001
    """--frame machine --exact: the Z-Y-X angles of R_W·ΔR·R_Wᵀ (explicit 4×4 products in the test),
    not R_W applied to ΔR's angles as if they were a vector (which is off by ~1e-4 µrad here and by
    ~1.7 µrad at 100 times these errors)."""
    data, model, cond = five_axis
    p = poses(12, seed=17)
    got = exact(model, p, cond, "machine")
    ref = Reference(data)
    for i in range(12):
        d, e = ref.error({k: float(v[i]) for k, v in p.items()}, frame="machine")
        np.testing.assert_allclose(got.position_um[i], d, rtol=0, atol=1e-7)
        np.testing.assert_allclose(got.orientation_urad[i], e, rtol=0, atol=1e-7)


def test_component_wise_rotations_match_the_matrix_ones() -> None:
    """The exact path's component-wise rotations (processing/volumetric/components.py) against the
    test-side 4×4 rotations, about each axis and composed."""
    from processing.volumetric import components as cp

    from .volumetric_reference import rot, rot_x, rot_y, rot_z

    angles = np.array([0.3, -1.2, 2.5])
    for axis, turn in enumerate((rot_x, rot_y, rot_z)):
        m = cp.mat_principal(axis, angles)
        for i, a in enumerate(angles):
            got = np.array([[np.broadcast_to(m[r][c], angles.shape)[i] for c in range(3)] for r in range(3)])
            np.testing.assert_allclose(got, turn(a)[:3, :3], atol=1e-15)
    z = cp.mat_zyx(0.1, -0.2, 0.3)
    np.testing.assert_allclose(np.array(z, dtype=float), rot(0.1, -0.2, 0.3)[:3, :3], atol=1e-15)
    prod = cp.mat_mul(z, cp.mat_principal(1, 0.7))
    np.testing.assert_allclose(np.array(prod, dtype=float), (rot(0.1, -0.2, 0.3) @ rot_y(0.7))[:3, :3], atol=1e-15)


def test_squareness_tilt_gives_cos_angle_minus_sin_s_exactly() -> None:
    """docs/volumetric.md: one squareness term turns the tilted axis by S about u_P × u_Q, so
    u_Q' = cos S·u_Q − sin S·u_P and cos∠(u_P, u_Q') = −sin S exactly (not −S: at S = 0.05 rad the two
    differ by S³/6 ≈ 2e-5)."""
    xs = Body("X", "prismatic", "tool", 0, 1.0, range=(0.0, 100.0))
    ys = Body("Y", "prismatic", "tool", 1, 1.0, range=(0.0, 100.0))
    s_urad = 50_000.0
    model = MachineModel((), (xs, ys), (squareness_element((xs, ys), ("X", "Y"), s_urad, "X", "Y"),),
                         primary="X", secondary="Y")
    zero = {"X": np.asarray(0.0), "Y": np.asarray(0.0)}
    moved = (exact(model, {**zero, "Y": np.asarray(100.0)}, {}).position_um
             - exact(model, zero, {}).position_um) * 1e-3  # mm: q·(u_Y' − u_Y)
    u_y = np.array([0.0, 1.0, 0.0]) + moved / 100.0
    s = s_urad * 1e-6
    assert np.linalg.norm(u_y) == pytest.approx(1.0, abs=1e-12)
    assert float(u_y @ [1.0, 0.0, 0.0]) == pytest.approx(-math.sin(s), abs=1e-12)
    assert abs(-math.sin(s) - (-s)) > 1e-5  # the old sentence's −S would be visibly wrong here


def test_seed000_rotary_errors_convert_by_turning_translations_and_rotations() -> None:
    """Seed 000 applies a rotary axis's error after its rotation, T_rot(θ)·E_seed; we apply it before,
    E_ours·T_rot(θ).  The same machine needs δ_ours = R(θ)·δ_seed AND ε_ours = R(θ)·ε_seed (docs/
    volumetric.md, "Seed 000"): checked against the seed's product written here with 4×4 matrices;
    turning ε alone leaves the translation errors pointing the wrong way (2.8 µm at 90°)."""
    from .volumetric_reference import rot, rot_z, trans

    delta_seed_um = np.array([2.0, 0.0, 0.0])
    eps_seed_urad = np.array([10.0, -6.0, 4.0])
    tool_mm = np.array([200.0, 50.0, 100.0])
    angles = np.arange(0.0, 361.0, 15.0)  # table nodes: the tables below are exact there

    def table(values: np.ndarray) -> dict:
        return {"positions": angles.tolist(), "values": values.tolist()}

    def machine(turn_delta: bool) -> MachineModel:
        turned_eps = np.array([rot_z(math.radians(a))[:3, :3] @ eps_seed_urad for a in angles])
        turned_delta = np.array([rot_z(math.radians(a))[:3, :3] @ delta_seed_um for a in angles])
        deltas = turned_delta if turn_delta else np.tile(delta_seed_um, (len(angles), 1))
        errors = {k: table(deltas[:, i]) for i, k in enumerate(("EX", "EY", "EZ"))}
        errors |= {k: table(turned_eps[:, i]) for i, k in enumerate(("EA", "EB", "EC"))}
        data = {"kind": "machine", "name": "seed 000 table", "tool": {"offset_mm": tool_mm.tolist()},
                "workpiece_chain": [{"name": "C", "type": "rotary", "direction": "+Z", "range": [0.0, 360.0],
                                     "errors": errors}],
                "tool_chain": [{"name": "S", "type": "fixed"}]}
        return machine_from_dict(data, "seed000.toml").model

    expected = []
    for a in angles:
        t_rot = rot_z(math.radians(a))
        w_seed = t_rot @ trans(delta_seed_um * 1e-3) @ rot(*(eps_seed_urad * 1e-6))  # error after rotation
        p = np.append(tool_mm, 1.0)
        expected.append((np.linalg.inv(w_seed) @ p - np.linalg.inv(t_rot) @ p)[:3] * 1e3)
    expected = np.array(expected)
    both = exact(machine(True), {"C": angles}, {}).position_um
    np.testing.assert_allclose(both, expected, rtol=0, atol=1e-4)  # second order in ε·L: < 1e-4 µm
    eps_only = exact(machine(False), {"C": angles}, {}).position_um
    gap = np.linalg.norm(eps_only - expected, axis=-1)  # |δ − R(θ)δ| = 2|δ| sin(θ/2): 2.8 µm at 90°
    np.testing.assert_allclose(gap, 2 * 2.0 * np.abs(np.sin(np.radians(angles) / 2)), rtol=0, atol=1e-4)
