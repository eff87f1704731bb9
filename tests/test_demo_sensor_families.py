"""The demo path end to end with the HL-G1 and the ILD1420 heads (real pty at
each family's line rate, the real drivers, the ILD1420 streaming): noise off,
the recovered profile matches the simulated surface, after removing a
least-squares line from both, to within what the family's resolution allows."""

from __future__ import annotations

import io
import json
from pathlib import Path

import numpy as np
import pytest

from acquisition.demo import run_demo

from .test_demo_end_to_end import ls_residual, truth_heights_um

ILD1420_RANGE_MM = 10.0  # the simulated head is an ILD1420-10
# value step of each family (mm): HL-G1 values come in 0.0001 mm; the ILD1420 sends counts
# with x = (counts * 1.02 / 65520 - 0.01) * MR, so one count is MR * 1.02 / 65520.
STEP_MM = {
    "panasonic-hlg1": 0.0001,
    "me-ild1420": ILD1420_RANGE_MM * 1.02 / 65520,
}
SIGN = {"panasonic-hlg1": "height", "me-ild1420": "gap"}
OTHER_CHANNELS_UM = 0.01  # interferometer channels' rounding: the Keyence demo test holds to 0.01 um in all


def residual_gain(x: np.ndarray) -> float:
    """max-row-sum norm of I - P, P the least-squares line projection: |LS residual of e| <= gain * max|e|."""
    a = np.vstack([np.ones_like(x), x]).T
    p = a @ np.linalg.solve(a.T @ a, a.T)
    return float(np.max(np.sum(np.abs(np.eye(len(x)) - p), axis=1)))


@pytest.mark.parametrize("sensor", sorted(STEP_MM))
def test_noise_free_profile_within_the_family_resolution(sensor: str, tmp_path: Path) -> None:
    stations = 6
    out = io.StringIO()
    res = run_demo(tmp_path / "run", stations=stations, seed=4, noise=False, samples=2, sensor=sensor, stream=out)
    assert res.outcome.exit_status == "success"
    meta = json.loads((res.run_dir / "run.json").read_text())
    assert meta["instruments"]["sensor"]["protocol"] == sensor
    assert meta["setup"]["geometry"]["sensor_sign"] == SIGN[sensor]
    assert f"simulated sensor     : {sensor} on " in out.getvalue() and "(pty /dev/pts/" in out.getvalue()

    prof = res.result.profile
    x_true, h_true = truth_heights_um(res.sim.world)
    assert len(prof) == len(h_true) == stations
    x = prof["x_mm"].to_numpy()
    err = ls_residual(x, prof["height_um"].to_numpy()) - ls_residual(x_true, h_true)
    # Noise off, every reading is the true value rounded to the family's step: |e| <= step / 2 at each
    # station; the datum's rounding is a constant, which the line removes with everything else.
    tol_um = residual_gain(x) * STEP_MM[sensor] * 1000.0 / 2 + OTHER_CHANNELS_UM
    assert np.max(np.abs(err)) < tol_um
    # the surface has um-level waviness, several steps, so a wrong sign could not pass
    assert np.ptp(ls_residual(x_true, h_true)) > 10 * tol_um
