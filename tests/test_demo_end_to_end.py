"""The demo path end to end over the real pty and the real Modbus TCP server:
the recovered profile matches the simulated surface after removing a
least-squares line from both."""

from __future__ import annotations

import io
import json
import math
from pathlib import Path

import numpy as np

from acquisition.demo import run_demo
from mocks.world import Noise


def ls_residual(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    a = np.vstack([np.ones_like(x), x]).T
    coef, *_ = np.linalg.lstsq(a, y, rcond=None)
    return y - a @ coef


def truth_heights_um(world) -> tuple[np.ndarray, np.ndarray]:
    """Surface height at each station's sample point (the world's own record)."""
    last = {}
    for st, hit in world.sample_log:
        last[st] = hit
    hits = np.array([last[k] for k in sorted(last)])
    return hits[:, 0], (hits[:, 1] - hits[0, 1]) * 1000.0


def test_noise_free_profile_within_10_nm(tmp_path: Path) -> None:
    res = run_demo(tmp_path / "run", stations=20, seed=4, noise=False, samples=2, stream=io.StringIO())
    assert res.outcome.exit_status == "success"
    prof = res.result.profile
    x_true, h_true = truth_heights_um(res.sim.world)
    assert len(prof) == len(h_true) == 20
    err = ls_residual(prof["x_mm"].to_numpy(), prof["height_um"].to_numpy()) - ls_residual(x_true, h_true)
    # The only error left is the sensor's display resolution (0.01 um steps).
    assert np.max(np.abs(err)) < 0.01
    # and the profile is not trivially flat: the surface has um-level waviness
    assert np.ptp(h_true) > 2.0
    # The exact method works in the laser's frame (the simulated world's): the profile is the
    # surface itself, no line removed, with the datum block's pitch estimated from the first step.
    world = res.sim.world
    datum = res.result.datum
    assert datum is not None and datum.source["pitch"] == "estimated"
    assert abs(datum.pitch_urad - world.datum_angles_urad()["pitch"]) < 0.01
    assert abs(world.datum_angles_urad()["pitch"]) > 1.0  # the datum block does stand tilted
    assert np.max(np.abs(prof["height_um"].to_numpy() - h_true)) < 0.01
    assert np.max(np.abs(prof["x_mm"].to_numpy() - (x_true - x_true[0]))) < 1e-6


def test_noisy_profile_within_four_sigma(tmp_path: Path) -> None:
    samples = 5
    res = run_demo(tmp_path / "run", stations=20, seed=9, noise=True, samples=samples, stream=io.StringIO())
    n = Noise()
    b = res.sim.world.block
    p, q = np.array(b.mirror_mm), np.array(b.sensor_head_mm)
    # h = stry + s + (xQ-xP) ez - (zQ-zP) ex, each term relative to the first station:
    # two independent captures per term; the sensor mean is over `samples` readings.
    var_one = (n.straightness_um**2 + n.sensor_um**2 / samples
               + ((q[0] - p[0]) * 1e3 * n.angle_urad * 1e-6) ** 2
               + ((q[2] - p[2]) * 1e3 * n.angle_urad * 1e-6) ** 2)
    sigma_h = math.sqrt(2 * var_one)
    prof = res.result.profile
    x_true, h_true = truth_heights_um(res.sim.world)
    err = ls_residual(prof["x_mm"].to_numpy(), prof["height_um"].to_numpy()) - ls_residual(x_true, h_true)
    assert np.max(np.abs(err)) < 4 * sigma_h
    assert np.std(err) > 0.1 * sigma_h  # the noise really was on


def test_demo_writes_run_and_results(tmp_path: Path) -> None:
    out = io.StringIO()
    res = run_demo(tmp_path / "run", stations=5, seed=1, stream=out)
    run = res.run_dir
    meta = json.loads((run / "run.json").read_text())
    assert meta["status"] == "complete" and meta["setup"]["stations"] == 5
    assert meta["instruments"]["sensor"]["protocol"] == "keyence-lkg"
    assert meta["instruments"]["interferometer"]["model"] == "SIM-6DOF-IFM"
    # the stable name the driver opened (a symlink to the pty, removed when the run ended)
    endpoint = Path(meta["instruments"]["sensor"]["endpoint"])
    assert endpoint.name == "sensor" and endpoint.parent.name.startswith("guideway-sim-")
    assert not endpoint.parent.exists()
    assert f"on {endpoint} (pty /dev/pts/" in out.getvalue()
    for name in ("profile.csv", "profile.png", "summary.json"):
        assert (run / "results" / name).stat().st_size > 0
    assert (run / "results" / "profile.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    text = out.getvalue()
    assert "straightness (endpoint reference line)" in text and "least squares" in text
