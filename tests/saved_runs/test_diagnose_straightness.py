"""Effects hidden in simulated straightness runs (``guideway simulate``: the gauge block on the
simulated guideway, mocks/world.py, with the scenario's effects applied by mocks/effects.py from
their documented equations): ``diagnose`` names each, recovers its parameter within 4 standard
errors and brings the residual to the noise; a null run names nothing over 20 seeds.

The height noise of a point follows from the simulated instruments by first-order propagation
of the decoupling h = stry + s + (xQ − xP)·Δεz − (zQ − zP)·Δεx (docs/conventions.md): straightness
σ, the sensor's σ over the samples averaged, the angle σ through the lever arms (the datum's own
noise is common to every point and goes into the nuisance).  The lin channel's noise is the
placement scatter of the block.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from acquisition.simulated.scenario import STRAIGHTNESS_NOISE, default_geometry, scenario_from_dict
from acquisition.simulated.synthetic import simulate_run
from saved_runs.diagnosis.diagnose import diagnose_run
from saved_runs.diagnosis.model_file import model_from_dict

SAMPLES = 5
GEO = default_geometry()
LEVER_X_MM = GEO["sensor_mm"][0] - GEO["mirror_mm"][0]
LEVER_Z_MM = GEO["sensor_mm"][2] - GEO["mirror_mm"][2]
N = STRAIGHTNESS_NOISE
SIGMA_H_UM = math.sqrt(N["straightness_um"] ** 2 + N["sensor_um"] ** 2 / SAMPLES
                       + (LEVER_X_MM * 1e-3 * N["angle_urad"]) ** 2 + (LEVER_Z_MM * 1e-3 * N["angle_urad"]) ** 2)
SIGMA_LIN_UM = math.hypot(N["placement_um"], N["position_um"])

XS = np.arange(0.0, 2001.0, 50.0)
REFERENCE = {"type": "profile_table", "positions_mm": XS.tolist(),
             "height_um": (12 * np.sin(XS / 130.0) + 6 * np.cos(XS / 47.0)).tolist()}
DEFECT = {"type": "profile_table", "positions_mm": XS.tolist(),
          "height_um": np.where(np.abs(XS - 800) < 200, 1.5 * np.cos((XS - 800) / 200 * np.pi / 2) ** 2, 0).tolist()}
BASE = {"kind": "straightness", "block": {"length_mm": 100.0, "stations": 16, "return_pass": True,
                                          "samples_per_reading": SAMPLES},
        "timing": {"seconds_per_station": 30.0}, "surface": {"waves": []}}


def simulated(tmp_path: Path, effects: list[dict], seed: int = 2, **extra) -> Path:
    scenario = scenario_from_dict({**BASE, **extra, "effect": effects}, "test scenario")
    out, _ = simulate_run(scenario, tmp_path / f"run{seed}", seed=seed)
    return out


def with_reference():
    return model_from_dict({"kind": "straightness", "effect": [REFERENCE]}, "reference model")


CASES = {
    # the profile itself unknown: only the forward-return redundancy, which sees a drift
    "sensor_drift": ({"um_per_min": 0.02}, None, "height"),
    # against the reference straightedge
    "sensor_gain": ({"ppm": 20000.0}, "reference", "height"),
    "lever_arm": ({"error_mm": 3.0}, "reference", "height"),
    "block_length": ({"um_per_block": 8.0}, None, "lin"),
}


@pytest.mark.parametrize("kind", list(CASES))
def test_every_hidden_straightness_effect_is_named_and_recovered(tmp_path: Path, kind: str) -> None:
    params, model, channel = CASES[kind]
    effects = [{"type": kind, **params}] + ([REFERENCE] if model else [])
    d = diagnose_run(simulated(tmp_path, effects), with_reference() if model else None)
    assert d.named == [kind]
    assert d.ambiguous == []
    ch = next(c for c in d.channels if c.obs.channel == channel)
    (step,) = ch.steps
    (name, value), = params.items()
    assert abs(step.effect.params[name] - value) <= 4 * step.fit.se[-1][name], (step.effect.params, step.fit.se)
    sigma = SIGMA_H_UM if channel == "height" else SIGMA_LIN_UM
    assert ch.final.rms_um <= 1.2 * sigma
    assert 0.7 * sigma < ch.noise.sigma_um < 1.3 * sigma


def test_a_surface_defect_against_the_reference_is_named_as_a_profile_table(tmp_path: Path) -> None:
    """The straightedge carries a 1.5 um bump the certified reference does not: a free profile table at
    the stations recovers it, up to the offset and slope of the reference line (its gauge)."""
    d = diagnose_run(simulated(tmp_path, [REFERENCE, DEFECT]), with_reference())
    assert d.named == ["profile_table"]
    ch = d.primary
    (step,) = ch.steps
    nodes = np.array(step.effect.params["positions_mm"])
    want = np.interp(nodes, DEFECT["positions_mm"], DEFECT["height_um"])
    design = np.column_stack([np.ones_like(nodes), nodes])
    want = want - design @ np.linalg.lstsq(design, want, rcond=None)[0]  # the gauge: no offset, no slope
    got, se = np.array(step.effect.params["height_um"]), np.array(step.fit.se[-1]["height_um"])
    assert np.all(np.abs(got - want) <= 4 * se)
    assert ch.final.rms_um <= 1.2 * SIGMA_H_UM


def test_without_reference_the_gain_is_not_a_candidate(tmp_path: Path) -> None:
    """A gain error is the same on the forward and the return pass: without a reference profile the
    redundancy cannot see it, so it is reported as not testable and nothing is named."""
    d = diagnose_run(simulated(tmp_path, [REFERENCE, {"type": "sensor_gain", "ppm": 20000.0}]))
    assert d.named == []
    assert "sensor_gain" in d.to_dict()["not_testable"]


def test_null_straightness_runs_name_nothing_over_20_seeds(tmp_path: Path) -> None:
    for seed in range(20):
        run = simulated(tmp_path, [REFERENCE], seed=100 + seed,
                        block={"length_mm": 100.0, "stations": 10, "return_pass": True, "samples_per_reading": 3})
        model = with_reference() if seed % 2 else None
        d = diagnose_run(run, model)
        assert d.named == [] and d.ambiguous == [], (seed, d.named, d.ambiguous)
