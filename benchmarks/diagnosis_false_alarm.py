"""False-alarm rate of the diagnosis' selection rule, measured on null runs (nothing hidden).

Simulates runs whose scenario hides no effect (``guideway simulate``, many seeds) and diagnoses
each against the model it was simulated with: a run where anything is named, or called
ambiguous, is a false alarm.  Positioning runs record time, pitch and yaw and a cycling air
index, so every candidate of the library is tested; straightness runs have a return pass and are
diagnosed without and with their reference profile.  Prints the rate per kind with its 95 %
Clopper-Pearson interval (docs/diagnosis.md quotes the figures).

At α = 0.001 a false alarm is too rare to be measured on a few hundred runs, so the calibration the
bound rests on is measured too: the first round's F-test p-values of every candidate (uniform when
the test is calibrated: fractions below 0.05 and 0.01), and the per-run rate at which the smallest
Bonferroni-adjusted p-value (p · C · K) falls below 0.05 — the false-alarm rate criterion 1 alone
would give at α = 0.05, which the bound says is at most 0.05.

    python benchmarks/diagnosis_false_alarm.py [--seeds 200]

``--ar1`` measures the rule under serially correlated noise instead: the positioning null runs
simulated without noise, then AR(1) noise added in time order (e_t = φ e_{t−1} + w_t, marginal σ
``--sigma-um``, 0.2 µm) at φ = 0.7 and 0.9 (``--phi``): the false-alarm rate, and the rate at which a
single hidden effect (``--effect``, thermal_drift) of 5 standard errors (``--se``) is named (and, apart, the rate at
which it is only reported ambiguous with another effect: found, not attributed), the standard error
being that of the generalised least-squares estimate under the true noise covariance, computed here:
SE² = [(Xᵀ Σ⁻¹ X)⁻¹]_kk, X = [1, the effect's column], Σ_ij = σ² φ^|i−j| in time order.

    python benchmarks/diagnosis_false_alarm.py --ar1 [--seeds 100] [--phi 0.7 0.9] [--phi-known]

``--phi-known`` gives the tests the true φ instead of the estimate from the run (the AR(1) estimator of
processing/diagnosis/serial.py replaced for the benchmark): what estimating φ from the run costs.
``--phi-ml`` replaces it by the maximum-likelihood φ (the exact AR(1) likelihood of the regression,
concentrated on φ) instead: less biased towards 1, evaluated as an alternative (docs/diagnosis.md).

``--history H`` gives each diagnosis H earlier null runs of the same simulated machine (same φ and σ, their
own noise) through ``--noise-from``: φ is then estimated from H + 1 runs instead of one.

``--bound REPS`` computes how well any test can do on one run: the Neyman–Pearson power against the
hidden drift of 5 GLS standard errors at φ (the benchmark run's own times, offset unknown), of the
most powerful test that holds its false alarms to α (1 %, 0.5 %, 0.2 %) on one null machine of
coefficient φ₀ ≥ φ and marginal σ₀ (the least favourable of a grid, evaluated again on fresh draws).
By the Neyman–Pearson lemma no test that keeps its false alarms at α on every machine with φ₀ ≤ 0.98
detects the drift more often:

    python benchmarks/diagnosis_false_alarm.py --bound 50000 --phi 0.9 0.7

``--drift-mc REPS`` isolates the one test under correlated noise, outside the tool: y = a + b·t + AR(1)
noise at n = 210 equally spaced points, the drift b tested by the Prais–Winsten GLS t-statistic with φ
known, φ̂ by matching moments (serial.py's estimator) or by maximum likelihood; prints each statistic's
null tail P(|z| > 3.54) (the positioning rule's threshold) and its power at 5 GLS standard errors, at
that threshold and at the thresholds that hold its null tail to 0.002, 0.001 and 0.0005:

    python benchmarks/diagnosis_false_alarm.py --drift-mc 5000 --phi 0.9
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import tempfile
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
from scipy import stats  # noqa: E402

from acquisition.simulated.scenario import scenario_from_dict  # noqa: E402
from acquisition.simulated.synthetic import simulate_run  # noqa: E402
from saved_runs.diagnosis.diagnose import diagnose_run  # noqa: E402
from saved_runs.diagnosis.model_file import model_from_dict  # noqa: E402

POSITIONING = {
    "kind": "positioning",
    "axis": {"start_mm": 0.0, "end_mm": 1000.0, "runs": 5, "targets_mm": [
        0.0, 47.2, 103.9, 151.3, 196.8, 253.5, 298.1, 346.9, 404.2, 447.6, 502.3, 549.0, 601.7, 646.2, 698.8,
        752.4, 797.1, 853.6, 898.9, 951.2, 1000.0]},
    "conditions": {"air_cycle_c": 0.3, "cycle_period_min": 7.0},
    "motion": {"pitch_amplitude_urad": 6.0, "pitch_wavelength_mm": 700.0, "yaw_amplitude_urad": 3.0,
               "yaw_wavelength_mm": 260.0},
}
XS = [float(x) for x in range(0, 2001, 50)]
REFERENCE = {"type": "profile_table", "positions_mm": XS,
             "height_um": [12 * math.sin(x / 130.0) + 6 * math.cos(x / 47.0) for x in XS]}
BLOCK = {"length_mm": 100.0, "stations": 16, "return_pass": True}
# without a reference: the demo's wavy guideway; with one: a straightedge that is exactly the reference
STRAIGHTNESS = {"kind": "straightness", "block": BLOCK, "surface": {"waves": [[3.0, 640.0, 0.3]]}}
STRAIGHTEDGE = {"kind": "straightness", "block": BLOCK, "surface": {"waves": []}, "effect": [REFERENCE]}


def clopper_pearson(k: int, n: int) -> tuple[float, float]:
    lo = 0.0 if k == 0 else float(stats.beta.ppf(0.025, k, n - k + 1))
    hi = 1.0 if k == n else float(stats.beta.ppf(0.975, k + 1, n - k))
    return lo, hi


def count(label: str, scenario: dict, model: dict | None, seeds: int, tmp: Path) -> None:
    sc = scenario_from_dict(scenario, label)
    m = model_from_dict(model, "model") if model else None
    alarms, examples = 0, []
    p_values: list[float] = []
    adjusted_below = rounds = 0
    for seed in range(seeds):
        out = tmp / f"{label.replace(' ', '_')}_{seed}"
        simulate_run(sc, out, seed=10_000 + seed)
        d = diagnose_run(out, m)
        if d.named or d.ambiguous:
            alarms += 1
            examples.append((seed, d.named, d.ambiguous))
            continue
        # nothing added: the last round is the first one, every candidate tested against the model
        first = [t for ch in d.channels for t in ch.last_round]
        if first:
            rounds += 1
            p_values += [t.p_value for t in first]
            adjusted_below += min(t.p_value * d.primary.rule.alpha / t.p_threshold for t in first) < 0.05  # p·C·K
    lo, hi = clopper_pearson(alarms, seeds)
    print(f"{label}: {alarms} false alarm(s) in {seeds} null runs, rate {alarms / seeds:.4f} "
          f"(95 % interval {lo:.4f} … {hi:.4f})" + (f"; e.g. {examples[:3]}" if examples else ""))
    p = np.array(p_values)
    lo, hi = clopper_pearson(adjusted_below, rounds)
    print(f"  calibration: {len(p)} candidate p-values, {np.mean(p < 0.05):.3f} below 0.05, "
          f"{np.mean(p < 0.01):.4f} below 0.01; smallest p·C·K below 0.05 in {adjusted_below} of {rounds} runs "
          f"({adjusted_below / max(rounds, 1):.3f}, 95 % interval {lo:.3f} … {hi:.3f})")


# one unit of each effect's parameter, as the scenario states it (the column the GLS standard error is of)
UNIT_EFFECTS = {"thermal_drift": ("um_per_min", lambda p, t: t), "linear_scale": ("ppm", lambda p, t: p * 1e-3),
                "thermal_growth": ("ppm_per_min", lambda p, t: p * t * 1e-3)}


def ar1_noise(n: int, phi: float, sigma_um: float, rng: np.random.Generator) -> np.ndarray:
    """A stationary AR(1) sequence of marginal standard deviation ``sigma_um``."""
    e = np.empty(n)
    e[0] = rng.normal(0.0, sigma_um)
    w = rng.normal(0.0, sigma_um * math.sqrt(1.0 - phi * phi), n)
    for i in range(1, n):
        e[i] = phi * e[i - 1] + w[i]
    return e


def with_ar1_noise(run_dir: Path, phi: float, sigma_um: float, seed: int) -> None:
    """Add AR(1) noise in time order to a noise-free simulated run's readings (µm → mm)."""
    points = pd.read_csv(run_dir / "points.csv")
    order = np.argsort(points["time_s"].to_numpy(), kind="stable")
    noise = np.empty(len(points))
    noise[order] = ar1_noise(len(points), phi, sigma_um, np.random.default_rng(seed))
    points["reading_mm"] = points["reading_mm"] + noise * 1e-3
    points.to_csv(run_dir / "points.csv", index=False, float_format="%.12g")


def gls_standard_error(column: np.ndarray, order: np.ndarray, phi: float, sigma_um: float) -> float:
    """SE of the coefficient of ``column`` fitted with an offset by GLS under AR(1) noise (time ``order``)."""
    x = np.column_stack([np.ones(len(column)), column])[order]
    k = np.arange(len(column))
    cov = sigma_um**2 * phi ** np.abs(k[:, None] - k[None, :])
    info = x.T @ np.linalg.solve(cov, x)
    return float(math.sqrt(np.linalg.inv(info)[1, 1]))


def ml_ar1_coefficient(residual_ordered: np.ndarray, basis_ordered: np.ndarray) -> float:
    """Maximum-likelihood AR(1) coefficient of the errors behind a least-squares residual (both in time
    order): φ maximising the exact likelihood concentrated on φ, −(n/2) ln RSS(φ) + ½ ln(1 − φ²), RSS(φ) that
    of the Prais–Winsten-whitened regression on the design (its span: the residual stands for the target);
    clipped to [0, PHI_MAX] like the moment estimator (used with its detection gate)."""
    from scipy import optimize

    from processing.diagnosis import serial
    n = len(residual_ordered)
    if n < 8:
        return 0.0

    def whiten(v: np.ndarray, phi: float) -> np.ndarray:
        out = v.copy()
        out[0] = math.sqrt(1 - phi * phi) * v[0]
        out[1:] = v[1:] - phi * v[:-1]
        return out

    def neg_loglik(phi: float) -> float:
        rz = whiten(residual_ordered, phi)
        qz = np.linalg.qr(whiten(basis_ordered, phi))[0]
        rss = float(rz @ rz - np.sum((qz.T @ rz) ** 2))
        return 0.5 * n * math.log(rss) - 0.5 * math.log(1 - phi * phi)

    phi = float(optimize.minimize_scalar(neg_loglik, bounds=(-0.99, serial.PHI_MAX), method="bounded",
                                         options={"xatol": 1e-4}).x)
    return min(phi, serial.PHI_MAX) if phi * math.sqrt(n) > serial.PHI_Z else 0.0


def drift_monte_carlo(phi: float, reps: int, n: int = 210, seed: int = 1) -> None:
    """The drift test alone under AR(1) noise (unit marginal σ), φ known and estimated (see the docstring)."""
    from processing.diagnosis import serial
    rng = np.random.default_rng(seed)
    t = np.arange(n, dtype=float)
    x = np.column_stack([np.ones(n), t])
    k = np.arange(n)
    se = math.sqrt(np.linalg.inv(x.T @ np.linalg.solve(phi ** np.abs(k[:, None] - k[None, :]), x))[1, 1])
    grid = np.arange(0.0, 0.99, 0.0025)
    q = np.linalg.qr(x)[0]
    expected = np.array([serial.expected_lag1(q, f) for f in grid])  # increasing in φ: inverted by interpolation

    def whiten(v: np.ndarray, f: float) -> np.ndarray:
        out = v.copy()
        out[..., 0] = math.sqrt(1 - f * f) * v[..., 0]
        out[..., 1:] = v[..., 1:] - f * v[..., :-1]
        return out

    z_of: dict[str, dict[str, np.ndarray]] = {}
    for label, delta in (("null", 0.0), ("drift", 5.0)):
        e = np.empty((reps, n))
        e[:, 0] = rng.normal(size=reps)
        w = rng.normal(size=(reps, n)) * math.sqrt(1 - phi**2)
        for i in range(1, n):
            e[:, i] = phi * e[:, i - 1] + w[:, i]
        y = e + delta * se * t
        r = y - (y @ q) @ q.T
        r1 = np.sum(r[:, 1:] * r[:, :-1], axis=1) / np.sum(r * r, axis=1)
        i_moment = np.searchsorted(grid, np.clip(np.interp(r1, expected, grid), 0.0, grid[-1]))
        loglik = np.empty((len(grid), reps))
        z = np.empty((len(grid), reps))
        for g, f in enumerate(grid):  # every statistic at every φ of the grid, then read at each estimate
            xz, yz = whiten(x.T, f).T, whiten(y, f)
            beta = np.linalg.lstsq(xz, yz.T, rcond=None)[0]
            rss = np.sum((yz - (xz @ beta).T) ** 2, axis=1)
            loglik[g] = -0.5 * n * np.log(rss) + 0.5 * math.log(1 - f * f)
            z[g] = beta[1] / np.sqrt(rss / (n - 2) * np.linalg.inv(xz.T @ xz)[1, 1])
        cols = np.arange(reps)
        picks = {"known": np.full(reps, int(np.argmin(np.abs(grid - phi)))),
                 "moment": np.minimum(i_moment, len(grid) - 1), "ml": np.argmax(loglik, axis=0)}
        z_of[label] = {m: z[i, cols] for m, i in picks.items()}
    print(f"drift test alone, AR(1) phi {phi}, n {n}, {reps} runs of each:")
    for m in ("known", "moment", "ml"):
        null, alt = np.abs(z_of["null"][m]), z_of["drift"][m]
        line = f"  phi {m}: |z| > 3.54 in {np.mean(null > 3.54):.4f} of null runs, power {np.mean(alt > 3.54):.3f}"
        for a in (0.002, 0.001, 0.0005):
            c = float(np.quantile(null, 1 - a))
            line += f"; null tail {a}: |z| > {c:.2f}, power {np.mean(alt > c):.3f}"
        print(line)


def power_bound(phi: float, reps: int, tmp: Path, n_se: float = 5.0) -> None:
    """The Neyman–Pearson bound of ``--bound`` (see the docstring), on the contrasts of the run (the offset
    unknown: the tool's tests are invariant to it)."""
    out = tmp / f"bound_{phi}"
    simulate_run(scenario_from_dict(POSITIONING, "bound"), out, seed=1, noise=False)
    t = np.sort(pd.read_csv(out / "points.csv")["time_s"].to_numpy()) / 60.0
    n = len(t)
    k = np.arange(n)

    def corr(f: float) -> np.ndarray:
        return f ** np.abs(k[:, None] - k[None, :])

    size = n_se * gls_standard_error(t, k, phi, 1.0)  # marginal σ 1: σ₀ below is in units of the true σ
    contrasts = np.linalg.qr(np.ones((n, 1)), mode="complete")[0][:, 1:]  # orthonormal, orthogonal to the offset
    mean = contrasts.T @ (size * t)
    cov1 = contrasts.T @ corr(phi) @ contrasts
    m1 = np.linalg.solve(cov1, mean)
    alphas = (0.01, 0.005, 0.002)
    grid = np.arange(1.0, 3.001, 0.05)  # σ₀ / σ

    def powers(phi0: float, sigmas: np.ndarray, seed: int) -> np.ndarray:
        """NP power against the null (φ₀, σ₀) for every σ₀ of ``sigmas`` (rows) and α (columns), on draws of
        ``seed``: the log-likelihood ratio ln p₁ − ln p₀ without its constants, −½ (y − m)ᵀ cov₁⁻¹ (y − m)
        + ½ yᵀ cov₀⁻¹ y with cov₀ = σ₀² base, expanded in σ₀ so that the grid costs no further solve."""
        rng = np.random.default_rng(seed)
        y1 = mean[:, None] + np.linalg.cholesky(cov1) @ rng.standard_normal((n - 1, reps))
        d1 = y1 - mean[:, None]
        q1 = -0.5 * np.sum(d1 * np.linalg.solve(cov1, d1), axis=0)
        base = contrasts.T @ corr(phi0) @ contrasts
        u = np.linalg.cholesky(base) @ rng.standard_normal((n - 1, reps))  # null draws at σ₀ = 1
        a, b = np.sum(u * np.linalg.solve(cov1, u), 0), m1 @ u
        c = np.sum(u * np.linalg.solve(base, u), 0)
        e = np.sum(y1 * np.linalg.solve(base, y1), 0)
        out = np.empty((len(sigmas), len(alphas)))
        for i, s0 in enumerate(sigmas):
            lam0 = -0.5 * (s0 * s0 * a - 2 * s0 * b + m1 @ mean) + 0.5 * c
            lam1 = q1 + 0.5 * e / (s0 * s0)
            out[i] = [np.mean(lam1 > np.quantile(lam0, 1 - alpha)) for alpha in alphas]
        return out

    print(f"Neyman-Pearson bound, drift of {n_se:g} GLS standard errors at phi {phi}, {n} points, {reps} draws:")
    worst = dict.fromkeys(alphas, (2.0, 0.0, 0.0))
    for phi0 in (phi, *[f for f in (0.75, 0.8, 0.85, 0.9, 0.92, 0.94, 0.95, 0.96, 0.97, 0.98) if f > phi]):
        table = powers(phi0, grid, 3)
        for j, alpha in enumerate(alphas):
            i = int(np.argmin(table[:, j]))
            worst[alpha] = min(worst[alpha], (float(table[i, j]), phi0, float(grid[i])))
    for j, (alpha, (_, phi0, s0)) in enumerate(worst.items()):
        # the least favourable null again on fresh draws: the minimum over the grid is biased low by its own noise
        power = float(powers(phi0, np.array([s0]), 4)[0, j])
        print(f"  false alarms <= {alpha}: power <= {power:.3f} (least favourable null: phi0 {phi0}, "
              f"sigma0 {s0:.2f} sigma)")


def count_ar1(phi: float, seeds: int, sigma_um: float, effect: str, tmp: Path, n_se: float = 5.0,
              history: int = 0) -> None:
    sc = scenario_from_dict(POSITIONING, "ar1")
    alarms, found, ambiguous, examples = 0, 0, 0, []
    partners: dict[str, int] = {}
    name, unit = UNIT_EFFECTS[effect]
    size = None
    for seed in range(seeds):
        earlier = []  # the same machine's earlier null runs (--history)
        for h in range(history):
            earlier.append(tmp / f"ar1_{phi}_{seed}_earlier{h}")
            simulate_run(sc, earlier[-1], seed=60_000 + seed * history + h, noise=False)
            with_ar1_noise(earlier[-1], phi, sigma_um, 70_000 + seed * history + h)
        out = tmp / f"ar1_{phi}_{seed}"
        simulate_run(sc, out, seed=20_000 + seed, noise=False)
        with_ar1_noise(out, phi, sigma_um, seed)
        d = diagnose_run(out, noise_from=earlier)
        if d.named or d.ambiguous:
            alarms += 1
            examples.append((seed, d.named, d.ambiguous))
        if size is None:
            pts = pd.read_csv(out / "points.csv")
            t = (pts["time_s"].to_numpy() - pts["time_s"].min()) / 60.0
            order = np.argsort(t, kind="stable")
            size = n_se * gls_standard_error(unit(pts["target_mm"].to_numpy(), t), order, phi, sigma_um)
        hidden = scenario_from_dict({**POSITIONING, "effect": [{"type": effect, name: size}]}, "ar1 effect")
        out = tmp / f"ar1_{phi}_{seed}_effect"
        simulate_run(hidden, out, seed=30_000 + seed, noise=False)
        with_ar1_noise(out, phi, sigma_um, 50_000 + seed)
        d = diagnose_run(out, noise_from=earlier)
        found += effect in d.named
        # found but not attributed: reported ambiguous with another effect (counted apart, not as named)
        pair = next((g for g in d.ambiguous if effect in g), None)
        if effect not in d.named and pair is not None:
            ambiguous += 1
            for other in pair:
                if other != effect:
                    partners[other] = partners.get(other, 0) + 1
    lo, hi = clopper_pearson(alarms, seeds)
    told = f", phi from {history} earlier runs and this one" if history else ""
    print(f"AR(1) phi {phi}, marginal sigma {sigma_um} um{told}: {alarms} false alarm(s) in {seeds} null runs, "
          f"rate {alarms / seeds:.3f} (95 % interval {lo:.3f} … {hi:.3f})"
          + (f"; e.g. {examples[:3]}" if examples else ""))
    lo, hi = clopper_pearson(found, seeds)
    print(f"  {effect} at {n_se:g} GLS standard errors ({name} = {size:.4g}): named in {found} of {seeds} runs, "
          f"rate {found / seeds:.3f} (95 % interval {lo:.3f} … {hi:.3f}); reported ambiguous in {ambiguous} "
          f"(with {partners or 'nothing'}), missed in {seeds - found - ambiguous}")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=200)
    ap.add_argument("--only", choices=("positioning", "straightness", "reference"), default=None)
    ap.add_argument("--ar1", action="store_true", help="null runs and a 5-SE effect under AR(1) noise")
    ap.add_argument("--phi", type=float, nargs="+", default=[0.7, 0.9])
    ap.add_argument("--sigma-um", type=float, default=0.2)
    ap.add_argument("--effect", choices=sorted(UNIT_EFFECTS), default="thermal_drift")
    ap.add_argument("--se", type=float, default=5.0, help="size of the hidden effect in standard errors")
    ap.add_argument("--phi-known", action="store_true", help="--ar1: the tests whitened with the true phi")
    ap.add_argument("--phi-ml", action="store_true", help="--ar1: phi estimated by maximum likelihood")
    ap.add_argument("--drift-mc", type=int, default=0, metavar="REPS", help="the drift test alone, REPS runs")
    ap.add_argument("--history", type=int, default=0, metavar="H", help="--ar1: H earlier runs of the machine")
    ap.add_argument("--bound", type=int, default=0, metavar="REPS", help="the best any test can do on one run")
    args = ap.parse_args()
    if args.bound:
        with tempfile.TemporaryDirectory() as tmp:
            for phi in args.phi:
                power_bound(phi, args.bound, Path(tmp), args.se)
        return 0
    if args.drift_mc:
        for phi in args.phi:
            drift_monte_carlo(phi, args.drift_mc)
        return 0
    if args.ar1:
        with tempfile.TemporaryDirectory() as tmp:
            for phi in args.phi:
                if args.phi_known:
                    from processing.diagnosis import serial
                    serial.ar1_coefficient = lambda *_a, _phi=phi, **_k: _phi  # the oracle: the true phi
                    print(f"(the tests use the true phi {phi}, not an estimate)")
                elif args.phi_ml:
                    from processing.diagnosis import serial
                    serial.ar1_coefficient = ml_ar1_coefficient
                    print("(phi estimated by maximum likelihood)")
                count_ar1(phi, args.seeds, args.sigma_um, args.effect, Path(tmp), args.se, args.history)
        return 0
    with tempfile.TemporaryDirectory() as tmp:
        if args.only in (None, "positioning"):
            count("positioning", POSITIONING, None, args.seeds, Path(tmp))
        if args.only in (None, "straightness"):
            count("straightness without reference", STRAIGHTNESS, None, args.seeds, Path(tmp))
        if args.only in (None, "reference"):
            count("straightness with reference", STRAIGHTEDGE, {"kind": "straightness", "effect": [REFERENCE]},
                  args.seeds, Path(tmp))
    return 0


if __name__ == "__main__":
    sys.exit(main())
