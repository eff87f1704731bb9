"""Effects hidden in positioning data: ``diagnose`` must name each, recover its parameters and
close the gap; nothing is named on null data; two hidden effects are both named; effects the run
cannot tell apart are reported as ambiguous.

The data are written here from first principles, independently of the simulator (mocks/) and of
processing/: an ISO 230-2 linear cycle with its machine time (moves at the feed, a dwell at every
target), the effect equations of docs/diagnosis.md, Gaussian reading noise, and the run directory
files as docs/run-format.md describes them (readings already compensated, the air recorded).

Tolerances: every recovered parameter lies within 4 standard errors of the truth (a Gaussian
estimate misses that by chance with probability 6e-5); the standard errors are computed here, σ²(JᵀJ)⁻¹
with the true σ and J the derivatives of the equations below at the truth (the offset fitted
alongside; a table in its zero-sum gauge), and the ones the diagnosis reports must agree with them
within 25 % (their σ is estimated from the residual: relative standard error 1/√(2·dof) ≈ 4 %).  The
final RMS lies within 1.2× the true noise σ (a correct model leaves σ·√((n − p)/n) ≈ 0.98 σ), and the
noise estimated from the repeat approaches within 25 % of σ (relative standard error ≈ 5 % here).
"""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np
import pytest

from saved_runs.diagnosis.diagnose import diagnose_run
from saved_runs.diagnosis.model_file import model_from_dict
from tests.effect_equations import positioning_effect_um
from tui.cli import main

SIGMA_UM = 0.15
TARGETS_MM = (0.0, 47.2, 103.9, 151.3, 196.8, 253.5, 298.1, 346.9, 404.2, 447.6, 502.3, 549.0, 601.7, 646.2,
              698.8, 752.4, 797.1, 853.6, 898.9, 951.2, 1000.0)
FEED_MM_MIN = 2000.0
DWELL_S = 3.0
OVERRUN_MM = 5.0
N_REF = 1.000271373  # NIST: air at 20 C, 101325 Pa, 50 %RH, 633 nm (standards.md 3.4)
P_REF_PA = 101325.0


def linear_cycle(targets: tuple[float, ...], runs: int) -> list[dict]:
    """ISO 230-2 linear cycle: up over all targets, reverse beyond the last, down, reverse beyond the
    first; time advances by the move at the feed plus the dwell at each target (seconds)."""
    rows, t, at = [], 0.0, targets[0]
    for run in range(1, runs + 1):
        for direction, order in ((1, range(len(targets))), (-1, range(len(targets) - 1, -1, -1))):
            start = targets[0] - OVERRUN_MM if direction == 1 else targets[-1] + OVERRUN_MM
            t += abs(start - at) / FEED_MM_MIN * 60.0
            at = start
            for i in order:
                t += abs(targets[i] - at) / FEED_MM_MIN * 60.0 + DWELL_S
                at = targets[i]
                rows.append({"run": run, "direction": direction, "target_index": i + 1, "target_mm": targets[i],
                             "time_s": t})
    return rows


def pitch_profile_urad(p_mm: np.ndarray) -> np.ndarray:
    """A guideway's pitch: two waves and a tilt, not a single sinusoid."""
    return 6.0 * np.sin(2 * np.pi * p_mm / 700 + 0.3) + 3.0 * np.sin(2 * np.pi * p_mm / 260 + 1.1) + 5e-3 * p_mm


def effect_um(kind: str, q: dict, rows: list[dict], pitch: np.ndarray, yaw: np.ndarray, dn: np.ndarray) -> np.ndarray:
    """The documented equation of one effect (docs/diagnosis.md), µm per point of the cycle ``rows``."""
    t = np.array([r["time_s"] for r in rows]) / 60.0
    return positioning_effect_um(kind, q, [r["target_mm"] for r in rows], [r["direction"] for r in rows],
                                 t - t.min(), pitch, yaw, dn)


def write_run(path: Path, rows: list[dict], effects: list[tuple[str, dict]], *, seed: int,
              pitch_fn=None, temp_c=None, pressure_pa=None, targets=TARGETS_MM, noise_um=None) -> Path:
    """A compensated positioning run directory (run.json + points.csv, docs/run-format.md); ``noise_um``:
    the reading noise of every row (µm), instead of independent Gaussian noise of σ = SIGMA_UM."""
    rng = np.random.default_rng(seed)
    n = len(rows)
    P = np.array([r["target_mm"] for r in rows])
    t = np.array([r["time_s"] for r in rows])
    pitch_true = pitch_fn(P) if pitch_fn is not None else np.zeros(n)
    pitch = pitch_true + rng.normal(0, 0.1, n)
    yaw = rng.normal(0, 0.1, n)
    temp = temp_c(t) if temp_c is not None else np.full(n, 20.0)
    pres = pressure_pa(t) if pressure_pa is not None else np.full(n, P_REF_PA)
    # index change from the first point: (n - 1) proportional to the pressure at 20 C, 50 %RH (ideal gas)
    dn = (N_REF - 1) * (pres - pres[0]) / P_REF_PA
    dev = rng.normal(0, SIGMA_UM, n)
    if noise_um is not None:
        dev = np.array(noise_um, dtype=float)
    for kind, q in effects:
        dev += effect_um(kind, q, rows, pitch_true, yaw, dn)
    path.mkdir()
    meta = {"format": "guideway-run", "version": 2, "kind": "positioning", "status": "complete",
            "axis_type": "linear", "uid": f"test-{seed}", "points": n,
            "setup": {"axis_name": "X", "targets_mm": list(targets), "runs": max(r["run"] for r in rows),
                      "environment": {"readings_compensated": True, "wavelength_nm": 633.0}}}
    (path / "run.json").write_text(json.dumps(meta))
    cols = ["run", "direction", "target_index", "target_mm", "reading_mm", "time_s", "stry_um", "strz_um",
            "pitch_urad", "yaw_urad", "roll_urad", "air_temp_c", "air_pressure_hpa", "humidity_pct",
            "material_temp_c"]
    with open(path / "points.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(cols)
        for i, r in enumerate(rows):
            w.writerow([r["run"], r["direction"], r["target_index"], repr(r["target_mm"]),
                        repr(float(r["target_mm"] + dev[i] / 1000)), repr(r["time_s"]), 0.0, 0.0, repr(float(pitch[i])),
                        repr(float(yaw[i])), 0.0, repr(float(temp[i])), repr(float(pres[i] / 100)), 50.0, 20.0])
    return path


def true_standard_errors(effects: list[tuple[str, dict]], rows: list[dict], pitch: np.ndarray | None = None,
                         pressure_pa=None) -> list[dict[str, np.ndarray]]:
    """σ²(JᵀJ)⁻¹ at the truth, σ = SIGMA_UM: J holds the offset and the derivative of every effect's
    equation (effect_um) by each of its numeric parameters (central differences; a table's values: its
    hat functions, the offset projected out so that the inverse is the one of the zero-sum gauge)."""
    n = len(rows)
    t_s = np.array([r["time_s"] for r in rows])
    pitch = np.zeros(n) if pitch is None else pitch
    pres = pressure_pa(t_s) if pressure_pa is not None else np.full(n, P_REF_PA)
    dn = (N_REF - 1) * (pres - pres[0]) / P_REF_PA
    cols, owners = [np.ones(n)], []
    for index, (kind, q) in enumerate(effects):
        for name, v in q.items():
            if isinstance(v, str) or name == "positions_mm":
                continue
            if isinstance(v, list):
                for j in range(len(v)):
                    unit = {**q, name: list(np.eye(len(v))[j])}
                    hat = effect_um(kind, unit, rows, pitch, np.zeros(n), dn)
                    cols.append(hat - hat.mean())
                    owners.append((index, name))
                continue
            h = 1e-6 * max(abs(v), 1.0)
            up = effect_um(kind, {**q, name: v + h}, rows, pitch, np.zeros(n), dn)
            down = effect_um(kind, {**q, name: v - h}, rows, pitch, np.zeros(n), dn)
            cols.append((up - down) / (2 * h))
            owners.append((index, name))
    j = np.column_stack(cols)
    se = SIGMA_UM * np.sqrt(np.diag(np.linalg.pinv(j.T @ j, rcond=1e-10)))[1:]
    out: list[dict[str, list]] = [{} for _ in effects]
    for (index, name), s in zip(owners, se, strict=True):
        out[index].setdefault(name, []).append(float(s))
    return [{name: np.array(v) for name, v in d.items()} for d in out]


def check_recovered(effect, se: dict, truth: dict, true_se: dict[str, np.ndarray], k: float = 4.0,
                    se_rel: float = 0.25) -> None:
    """Every parameter within ``k`` true standard errors of the truth; the reported standard errors
    within ``se_rel`` of the true ones (about 4 / √(2·dof): their σ is estimated)."""
    for name, value in truth.items():
        if isinstance(value, str) or name == "positions_mm":
            assert effect.params[name] == (value if isinstance(value, str) else tuple(value))
            continue
        got, s, want = np.atleast_1d(effect.params[name]), np.atleast_1d(se[name]), np.atleast_1d(value)
        if isinstance(value, list):  # a table: compare in its zero-sum gauge
            want = want - np.mean(want)
        if name == "phase_rad":
            got = np.array([math.remainder(got[0] - value, 2 * math.pi) + value])
        s_true = true_se[name]
        assert np.all(np.abs(got - want) <= k * s_true), f"{effect.type}.{name}: {got} vs {want} (SE {s_true})"
        assert np.all(np.abs(s / s_true - 1) < se_rel), f"{effect.type}.{name}: SE {s} vs {s_true}"


def diagnose(path: Path, model: dict | None = None):
    m = model_from_dict({"kind": "positioning", **(model or {})}, "test model") if model is not None else None
    return diagnose_run(path, m)


def pressure_cycle(t_s: np.ndarray) -> np.ndarray:
    return P_REF_PA + 600.0 * np.sin(2 * np.pi * t_s / 420.0)


TABLE_NODES = [0.0, 120.0, 260.0, 400.0, 530.0, 700.0, 850.0, 1000.0]
TABLE_ERRORS = [0.0, 1.8, -0.6, 2.2, -1.5, 0.9, 2.5, -0.8]

CASES = {
    "linear_scale": ({"ppm": 3.0}, {}),
    "quadratic": ({"um_per_m2": 5.0}, {}),
    "backlash": ({"reversal_um": -2.5}, {}),
    "periodic": ({"amplitude_um": 0.8, "wavelength_mm": 230.0, "phase_rad": 1.0}, {}),
    "thermal_drift": ({"um_per_min": 0.05}, {}),
    "thermal_growth": ({"ppm_per_min": 0.05}, {}),
    "abbe": ({"offset_mm": 150.0, "channel": "pitch"}, {"pitch_fn": pitch_profile_urad}),
    "dead_path": ({"length_mm": 800.0}, {"pressure_pa": pressure_cycle}),
    "error_table": ({"positions_mm": TABLE_NODES, "error_um": TABLE_ERRORS}, {}),
}


@pytest.mark.parametrize("kind", list(CASES))
def test_every_hidden_effect_is_named_recovered_and_closes_the_gap(tmp_path: Path, kind: str) -> None:
    params, env = CASES[kind]
    rows = linear_cycle(TARGETS_MM, 5)
    run = write_run(tmp_path / "run", rows, [(kind, params)], seed=11, **env)
    d = diagnose(run)
    ch = d.primary
    assert d.named == [kind], d.named
    assert d.ambiguous == []
    (step,) = ch.steps
    truth = params
    if kind == "error_table":  # the candidate table has its nodes at the targets
        truth = {"positions_mm": list(TARGETS_MM), "error_um": list(np.interp(TARGETS_MM, TABLE_NODES, TABLE_ERRORS))}
    true_se = true_standard_errors([(kind, truth)], rows, env.get("pitch_fn", lambda p: 0 * p)(
        np.array([r["target_mm"] for r in rows])), env.get("pressure_pa"))
    check_recovered(step.effect, step.fit.se[-1], truth, true_se[0])
    assert ch.final.rms_um <= 1.2 * SIGMA_UM
    assert ch.baseline.rms_um > 1.5 * SIGMA_UM  # the effect was really there
    assert 0.75 * SIGMA_UM < ch.noise.sigma_um < 1.25 * SIGMA_UM


def test_null_runs_name_nothing_over_20_seeds(tmp_path: Path) -> None:
    """Nothing hidden (time, angles and a changing air index recorded, so every candidate is tested):
    over 20 seeds of small runs at most one names an effect or calls a pair ambiguous.  The positioning rule's
    false-alarm bound is α = 0.005 per run (docs/diagnosis.md): 20 runs hold no alarm with probability
    0.995²⁰ = 0.905, one with 0.091, two or more with 0.0045 — a test of the bound at 0.5 % (seed 1007 names a
    quadratic at p = 2.8e-4 against the Bonferroni threshold 5e-4: the one chance alarm the bound allows)."""
    targets = (0.0, 140.5, 282.1, 431.7, 566.0, 713.4, 858.8, 1000.0)
    rows = linear_cycle(targets, 3)
    alarms = []
    for seed in range(20):
        run = write_run(tmp_path / f"null{seed}", rows, [], seed=1000 + seed, targets=targets,
                        pressure_pa=pressure_cycle, pitch_fn=pitch_profile_urad)
        d = diagnose(run)
        if d.named or d.ambiguous:
            alarms.append((seed, d.named, d.ambiguous))
            continue
        assert d.primary.final.rms_um <= 1.2 * SIGMA_UM
    assert len(alarms) <= 1, alarms


@pytest.mark.parametrize("pair", [
    (("backlash", {"reversal_um": -2.0}), ("thermal_drift", {"um_per_min": 0.04})),
    (("periodic", {"amplitude_um": 0.8, "wavelength_mm": 230.0, "phase_rad": 1.0}), ("linear_scale", {"ppm": 3.0})),
    (("abbe", {"offset_mm": 120.0, "channel": "pitch"}), ("backlash", {"reversal_um": 1.5})),
    (("dead_path", {"length_mm": 800.0}), ("thermal_growth", {"ppm_per_min": 0.05})),
])
def test_two_hidden_effects_are_both_named(tmp_path: Path, pair) -> None:
    rows = linear_cycle(TARGETS_MM, 5)
    run = write_run(tmp_path / "run", rows, list(pair), seed=23, pitch_fn=pitch_profile_urad,
                    pressure_pa=pressure_cycle)
    d = diagnose(run)
    assert sorted(d.named) == sorted(k for k, _ in pair)
    assert d.ambiguous == []
    final = {e.type: (e, se) for e, se in zip(d.primary.final.effects, d.primary.final.se, strict=True)}
    true_se = true_standard_errors(list(pair), rows, pitch_profile_urad(np.array([r["target_mm"] for r in rows])),
                                   pressure_cycle)
    for (kind, params), s in zip(pair, true_se, strict=True):
        check_recovered(final[kind][0], final[kind][1], params, s)
    assert d.primary.final.rms_um <= 1.2 * SIGMA_UM


def test_two_periodic_errors_are_both_named(tmp_path: Path) -> None:
    """A screw lead and a longer wave: two periodic effects, each recovered (matched by wavelength)."""
    rows = linear_cycle(TARGETS_MM, 5)
    waves = [("periodic", {"amplitude_um": 0.8, "wavelength_mm": 230.0, "phase_rad": 1.0}),
             ("periodic", {"amplitude_um": 1.2, "wavelength_mm": 640.0, "phase_rad": -0.5})]
    d = diagnose(write_run(tmp_path / "run", rows, waves, seed=2))
    assert d.named == ["periodic", "periodic"] and d.ambiguous == []
    ch = d.primary
    fitted = sorted(zip(ch.final.effects, ch.final.se, strict=True), key=lambda f: f[0].params["wavelength_mm"])
    for (effect, se), truth, s in zip(fitted, waves, true_standard_errors(waves, rows), strict=True):
        check_recovered(effect, se, truth[1], s)
    assert ch.final.rms_um <= 1.2 * SIGMA_UM


def test_steps_told_again_after_the_backward_pass_keep_both_periodic_effects(tmp_path: Path, monkeypatch) -> None:
    """The steps are told again in order of evidence whenever the backward pass changed the model; two
    effects of one type (two periods) are both told, not merged by their common name."""
    from processing.diagnosis import select

    backward = select._backward
    monkeypatch.setattr(select, "_backward", lambda obs, final, n, rule: backward(obs, final, n, rule) or final)
    rows = linear_cycle(TARGETS_MM, 5)
    waves = [("periodic", {"amplitude_um": 0.8, "wavelength_mm": 230.0, "phase_rad": 1.0}),
             ("periodic", {"amplitude_um": 1.2, "wavelength_mm": 640.0, "phase_rad": -0.5})]
    d = diagnose(write_run(tmp_path / "run", rows, waves, seed=2))
    assert d.named == ["periodic", "periodic"]
    assert d.primary.final.rms_um <= 1.2 * SIGMA_UM


def test_the_loop_goes_on_after_the_steps_told_again_until_nothing_significant_is_left(tmp_path: Path,
                                                                                      monkeypatch) -> None:
    """Whatever the backward pass leaves (here: it is made to drop the last effect added, one still needed),
    the steps told again are followed by the rule's own rounds: the diagnosis never ends with a significant
    candidate left over."""
    from processing.diagnosis import select

    def drop_last(obs, final, n, rule):
        return select._without(obs, final, len(final.effects) - 1) if len(final.effects) > n else None

    monkeypatch.setattr(select, "_backward", drop_last)
    rows = linear_cycle(TARGETS_MM, 5)
    hidden = [("backlash", {"reversal_um": -2.0}), ("linear_scale", {"ppm": 3.0})]
    d = diagnose(write_run(tmp_path / "run", rows, hidden, seed=23))
    assert sorted(d.named) == ["backlash", "linear_scale"]
    assert not any(t.significant for t in d.primary.last_round)
    assert d.primary.final.rms_um <= 1.2 * SIGMA_UM


def test_five_targets_leave_a_scale_and_a_wave_to_the_free_table(tmp_path: Path) -> None:
    """Five targets over a metre (the ISO 230-2 minimum, as docs/setup-positioning.toml generates them)
    and three runs: a scale error, a long wave and backlash hidden.  A scale and a free wave with the offset
    are five parameters for five position means: they would reproduce any shape (issue 19, a step named as
    scale and waves), so position-only effects may use at most half the distinct positions, and the free
    error table describes the position error instead; backlash is named.  The table recovers the hidden
    curve at the targets (in its zero-sum gauge) and the backlash its value, within 4 standard errors
    computed here, and the gap closes."""
    targets = (4.404, 312.43, 572.084, 805.396, 995.31)
    rows = linear_cycle(targets, 3)
    hidden = [("linear_scale", {"ppm": 6.0}), ("periodic", {"amplitude_um": 4.0, "wavelength_mm": 700.0,
                                                            "phase_rad": 0.4}), ("backlash", {"reversal_um": -3.0})]
    p = np.array(targets)
    curve = 6.0 * p * 1e-3 + 4.0 * np.sin(2 * np.pi * p / 700.0 + 0.4)
    truth = [("error_table", {"positions_mm": list(targets), "error_um": list(curve)}),
             ("backlash", {"reversal_um": -3.0})]
    true_se = true_standard_errors(truth, rows)
    for seed in (0, 1, 9):
        d = diagnose(write_run(tmp_path / f"run{seed}", rows, hidden, seed=seed, targets=targets))
        assert sorted(d.named) == ["backlash", "error_table"] and d.ambiguous == [], (seed, d.named)
        ch = d.primary
        assert ch.final.rms_um <= 1.2 * SIGMA_UM, seed
        for s in ch.steps:
            assert s.in_final is not None and s.in_final.significant, (seed, s.test.label)
        budget = [t.position_budget for t in ch.steps[0].tested if t.effect.type == "periodic"]
        assert budget and budget[0][1] == 5 and budget[0][0] > 2.5, budget  # over half the positions: refused
        final = {e.type: (e, se) for e, se in zip(ch.final.effects, ch.final.se, strict=True)}
        for (kind, params), s_true in zip(truth, true_se, strict=True):
            check_recovered(final[kind][0], final[kind][1], params, s_true, se_rel=0.6)  # 30 points, 6 parameters


def test_four_hidden_effects_on_thirteen_targets_close_the_gap(tmp_path: Path) -> None:
    """A dead path, backlash, a scale error and an Abbe offset on a pitch that is a tilt and one wave,
    thirteen targets over 600 mm, three runs.  A long periodic error is the greedy first guess for the
    scale-plus-wave shape; the search keeps its wavelengths within the travel (one full period, as its
    grid; longer "periods" are a curve the refinement drifted to and a new search cannot find again, so the
    backward pass dropped them and left 4x the noise), and the loop ends only when nothing significant is
    left: every hidden effect is in the final model, at its value, and the gap closes."""
    targets = (0.0, 47.9, 95.3, 151.0, 204.1, 252.6, 298.7, 349.5, 402.2, 451.8, 497.9, 553.3, 600.0)
    rows = linear_cycle(targets, 3)

    def pitch(p):
        return 4.0e-3 * p + 8.0 * np.sin(2 * np.pi * p / 350.0)

    def pressure(t_s):
        return P_REF_PA + 800.0 * np.sin(2 * np.pi * t_s / 60.0)

    hidden = [("dead_path", {"length_mm": 1500.0}), ("backlash", {"reversal_um": -3.0}),
              ("linear_scale", {"ppm": 6.0}), ("abbe", {"offset_mm": 120.0, "channel": "pitch"})]
    for seed in (1, 2):
        d = diagnose(write_run(tmp_path / f"run{seed}", rows, hidden, seed=seed, targets=targets, pitch_fn=pitch,
                               pressure_pa=pressure))
        ch = d.primary
        assert ch.final.rms_um <= 1.2 * SIGMA_UM, (seed, d.named, d.ambiguous)
        assert not any(t.significant for t in ch.last_round), seed
        for e in ch.final.effects:
            assert e.type != "periodic" or e.params["wavelength_mm"] <= 600.0
        final = {e.type: (e, se) for e, se in zip(ch.final.effects, ch.final.se, strict=True)}
        assert sorted(final) == sorted(k for k, _ in hidden), (seed, sorted(final))
        p_true = pitch(np.array([r["target_mm"] for r in rows]))
        for (kind, params), s_true in zip(hidden, true_standard_errors(hidden, rows, p_true, pressure), strict=True):
            check_recovered(final[kind][0], final[kind][1], params, s_true, se_rel=0.4)  # 78 points, 5 parameters


def test_linear_scale_inside_a_free_error_table_is_ambiguous(tmp_path: Path) -> None:
    """The model holds a free error table: a hidden scale error is inside its span; the diagnosis
    reports the pair as ambiguous instead of naming either."""
    rows = linear_cycle(TARGETS_MM, 5)
    run = write_run(tmp_path / "run", rows, [("linear_scale", {"ppm": 4.0})], seed=5)
    model = {"effect": [{"type": "error_table", "positions_mm": [0.0, 250.0, 500.0, 750.0, 1000.0], "free": True}]}
    d = diagnose(run, model)
    assert d.named == []
    assert d.ambiguous == [["error_table", "linear_scale"]]
    assert d.primary.final.rms_um <= 1.2 * SIGMA_UM  # the free table absorbs it


def test_abbe_offset_on_a_linear_pitch_is_ambiguous_with_a_scale_error(tmp_path: Path) -> None:
    """A pitch that grows linearly along the axis makes an Abbe error a scale error: not guessed."""
    rows = linear_cycle(TARGETS_MM, 5)
    run = write_run(tmp_path / "run", rows, [("abbe", {"offset_mm": 200.0, "channel": "pitch"})], seed=6,
                    pitch_fn=lambda p: 0.012 * p)
    d = diagnose(run)
    assert d.named == []
    assert d.ambiguous == [["abbe", "linear_scale"]]
    assert d.primary.final.rms_um <= 1.2 * SIGMA_UM  # one of them was added to shrink the gap


def test_dead_path_under_a_linear_temperature_drift_is_ambiguous_with_thermal_drift(tmp_path: Path) -> None:
    """Air warming at a steady rate makes the index change linear in time: a dead path then looks
    exactly like a thermal drift of the set-up."""
    rows = linear_cycle(TARGETS_MM, 5)
    # -0.95 ppm/K (standards.md 3.4) at a steady 2 K/h: the pressure stands in for the same index change
    ramp = lambda t: P_REF_PA * (1 - 0.95e-6 * 2.0 * t / 3600 / (N_REF - 1))  # noqa: E731
    run = write_run(tmp_path / "run", rows, [("dead_path", {"length_mm": 2000.0})], seed=8, pressure_pa=ramp)
    d = diagnose(run)
    assert d.named == []
    assert d.ambiguous == [["dead_path", "thermal_drift"]]


def test_an_imported_compensated_run_is_diagnosed_like_an_acquired_one(tmp_path: Path, capsys) -> None:
    rows = linear_cycle(TARGETS_MM, 5)
    rng = np.random.default_rng(3)
    csv_path = tmp_path / "data.csv"
    with open(csv_path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["run", "direction", "target_mm", "reading_mm", "time_s"])
        for r in rows:
            dev = r["direction"] * -1.5 + 2.0 * r["target_mm"] / 1000 + rng.normal(0, SIGMA_UM)
            w.writerow([r["run"], r["direction"], r["target_mm"], repr(r["target_mm"] + dev / 1000), r["time_s"]])
    assert main(["import", "positioning", str(csv_path), "--out", str(tmp_path / "run"), "--compensated"]) == 0
    capsys.readouterr()
    assert main(["diagnose", str(tmp_path / "run"), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert sorted(out["named"]) == ["backlash", "linear_scale"]
    final = {e["type"]: e for e in out["final"]["model"]}
    assert abs(final["backlash"]["reversal_um"] + 3.0) <= 4 * final["backlash"]["se"]["reversal_um"]
    assert abs(final["linear_scale"]["ppm"] - 2.0) <= 4 * final["linear_scale"]["se"]["ppm"]
    assert out["final"]["rms_um"] <= 1.2 * SIGMA_UM
    assert "dead_path" in out["not_testable"]  # no air recorded


def test_an_imported_raw_run_is_compensated_and_diagnosed_like_an_acquired_one(tmp_path: Path, capsys) -> None:
    """Raw vacuum counts of an axis at a drifting material temperature, imported without --compensated:
    the deviations are compensated (air index, expansion to 20 C) before the diagnosis, which finds
    the hidden backlash and scale error and nothing of the air or the material.

    The counts are written from first principles: X_T = X_20 (1 + α (T_m − 20 °C)) (ISO 1), read in
    air of index n through a vacuum-wavelength count, reading = X_T · n; the air is held at the NIST
    reference point of standards.md 3.4 (Ciddor, 633 nm, 450 ppm CO2: n = 1.000271373)."""
    rows = linear_cycle(TARGETS_MM, 5)
    rng = np.random.default_rng(4)
    alpha, t_end = 11.5e-6, rows[-1]["time_s"]
    csv_path = tmp_path / "raw.csv"
    with open(csv_path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["run", "direction", "target_mm", "reading_mm", "time_s", "air_temp_c", "air_pressure_hpa",
                    "humidity_pct", "material_temp_c"])
        for r in rows:
            material_c = 20.2 + 0.6 * r["time_s"] / t_end  # 0.6 K during the run
            e_um = r["direction"] * -1.5 + 2.0 * r["target_mm"] / 1000 + rng.normal(0, SIGMA_UM)
            x20 = r["target_mm"] + e_um / 1000
            reading = x20 * (1 + alpha * (material_c - 20.0)) * N_REF
            w.writerow([r["run"], r["direction"], r["target_mm"], repr(reading), r["time_s"], 20.0, 1013.25, 50.0,
                        repr(material_c)])
    common = ["--equation", "ciddor", "--wavelength-nm", "633.0", "--co2-ppm", "450"]
    assert main(["import", "positioning", str(csv_path), "--out", str(tmp_path / "run"),
                 "--expansion-ppm-per-k", "11.5", *common]) == 0
    capsys.readouterr()
    assert main(["diagnose", str(tmp_path / "run"), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert sorted(out["named"]) == ["backlash", "linear_scale"] and out["ambiguous"] == []
    final = {e["type"]: e for e in out["final"]["model"]}
    assert abs(final["backlash"]["reversal_um"] + 3.0) <= 4 * final["backlash"]["se"]["reversal_um"]
    assert abs(final["linear_scale"]["ppm"] - 2.0) <= 4 * final["linear_scale"]["se"]["ppm"]
    assert out["final"]["rms_um"] <= 1.2 * SIGMA_UM
    # the same counts taken as compensated: the air index and the material's growth are left in them
    assert main(["import", "positioning", str(csv_path), "--out", str(tmp_path / "as_is"), "--compensated"]) == 0
    capsys.readouterr()
    assert main(["diagnose", str(tmp_path / "as_is"), "--json"]) == 0
    wrong = json.loads(capsys.readouterr().out)
    assert "thermal_growth" in wrong["named"]
    scale = next(e for e in wrong["final"]["model"] if e["type"] == "linear_scale")
    assert scale["ppm"] > 250.0  # (n - 1) = 271 ppm, and the expansion at 20.2 C
