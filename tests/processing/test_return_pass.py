"""Forward + return pass: averaged profile, closure error and drift, against a
profile with a known linear drift in time built here."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from processing.geometry import BlockGeometry
from processing.straightness import evaluate_straightness

GEOM = BlockGeometry((50.0, 110.0, 0.0), (150.0, 0.0, 40.0))
N = 9
DRIFT_UM_PER_S = 0.002


def surface(k: int) -> float:
    return 2.0 * np.sin(k / 2.0) + 0.1 * k


def run(return_stations: list[int]) -> pd.DataFrame:
    """Flat block motion (no angles): h = stry + sensor; the drift sits in stry."""
    rows = []
    t = 0.0
    plan = [(k, 0) for k in range(N)] + [(k, 1) for k in return_stations]
    for k, p in plan:
        rows.append({"station": k, "x_mm": 100.0 * k, "time_s": t, "lin_um": 0.0,
                     "stry_um": DRIFT_UM_PER_S * t + 0.3 * k, "strz_um": 0.0, "pitch_urad": 0.0,
                     "yaw_urad": 0.0, "roll_urad": 0.0, "sensor_mm": 0.5 + (surface(k) - 0.3 * k) * 1e-3,
                     "pass": p})
        t += 60.0
    return pd.DataFrame(rows)


@pytest.mark.parametrize("method", ["exact", "first-order", "patent"])
def test_round_trip(method: str) -> None:
    pts = run(list(reversed(range(N))))
    res = evaluate_straightness(pts, GEOM, method=method, mc_trials=0)
    true = np.array([surface(k) - surface(0) for k in range(N)])
    # forward at t = 60 k s, return at t = 60 (2N - 1 - k) s: their mean has the
    # drift of the run's middle instant, the same at every station
    mid = DRIFT_UM_PER_S * 60.0 * (2 * N - 1) / 2
    np.testing.assert_allclose(res.profile["height_um"], true + mid, atol=1e-9)
    rp = res.return_pass
    assert rp.closure_um == pytest.approx(DRIFT_UM_PER_S * 60.0 * (2 * N - 1), abs=1e-9)
    assert rp.drift_um_per_h == pytest.approx(DRIFT_UM_PER_S * 3600.0, rel=1e-9)
    np.testing.assert_allclose(rp.forward["height_um"], true + DRIFT_UM_PER_S * 60.0 * np.arange(N), atol=1e-9)
    d = res.to_dict()["return_pass"]
    assert [r["station"] for r in d["return"]] == list(reversed(range(N)))
    # the averaged profile's straightness equals the true profile's (drift gone)
    assert res.straightness_um()["minimum_zone"] == pytest.approx(
        evaluate_straightness(pts[pts["pass"] == 0].assign(stry_um=0.3 * np.arange(N)), GEOM,
                              method=method, mc_trials=0).straightness_um()["minimum_zone"], abs=1e-9)


def test_partial_return_pass_without_the_start_station() -> None:
    pts = run([8, 7, 6, 5])
    res = evaluate_straightness(pts, GEOM, method="first-order", mc_trials=0)
    assert res.return_pass.closure_um is None
    assert res.return_pass.drift_um_per_h == pytest.approx(DRIFT_UM_PER_S * 3600.0, rel=1e-9)
    assert len(res.profile) == N


def test_no_return_pass_and_bad_order() -> None:
    pts = run([])
    assert evaluate_straightness(pts, GEOM, mc_trials=0).return_pass is None
    assert "return_pass" not in evaluate_straightness(pts, GEOM, mc_trials=0).to_dict()
    with pytest.raises(ValueError, match="first point"):
        evaluate_straightness(run([8, 7]).iloc[::-1].reset_index(drop=True), GEOM, mc_trials=0)
