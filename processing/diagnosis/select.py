"""The diagnosis loop: evaluate a channel under the model, find where the residual stands out,
test every candidate effect the model lacks, name the best one when the evidence is
significant, add it, and repeat until nothing significant is left (docs/diagnosis.md).

Selection rule, per step, over the K candidates that can be tested on the channel — a
candidate is *significant* when all of:

1. the F-test of its added parameters has p < α / (C·K) (Bonferroni over the K candidates of
   the channel and the C channels of the run; for a periodic effect with a searched wavelength p
   is first corrected for the M independent wavelengths scanned, 1 − (1 − p)^M), α = 0.001;
2. it lowers the Schwarz criterion by at least 10 (BIC; "very strong" evidence, Kass & Raftery
   1995);
3. it lowers the grouped cross-validation RMSE (folds = whole approach series, or pass and
   station block; skipped where no fold can be held out);
4. and 5., for an effect of the position alone (scale, sag, periodic): the position parameters of
   the model with it stay within half the distinct positions, and it lowers the RMSE of predicting
   held-out positions.

Criteria 1 and 2 compare the residual sums of squares after whitening for AR(1) errors in time
order (serial.py: feasible generalised least squares, φ estimated from the larger model and pooled
with the estimates of earlier runs of the machine when the rule carries them).

The best significant candidate (lowest BIC; a physical effect before a free table, which is
tried only when no physical effect is significant) is added and the loop repeats.  A backward
pass then drops an added effect that is not significant in the final model, swaps it for a
candidate that explains more in its place, or, when it is rivalled, replaces it by a pair of
candidates that lowers the BIC by the margin with both significant (one effect can mimic the sum
of two: a growth for a sag and a dead path).  Ambiguity is judged in the final model: a
candidate that, in place of one of its free effects, is significant, comes within 10 of its BIC
and adds nothing significant once the effect is in, explains the same residual — both are
reported as ambiguous and the step is not named (a candidate strictly more general than the
effect, a table around a linear scale, is not a rival; a linear scale inside a free table of
the model is).
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from scipy import stats

from ..effects import Effect
from . import basis, serial
from .fit import (
    Fit,
    FoldFits,
    bic,
    cv_rmse,
    fit_model,
    fold_fits,
    free_wavelength,
    orthonormal_basis,
    solve,
    wavelength_grid,
)
from .observations import Observations, fold_ids, group_ids
from .plausible import implausible


@dataclass(frozen=True)
class Rule:
    """Thresholds of the selection rule."""

    alpha: float = 1e-3
    channels: int = 1  # channels diagnosed in the run: each gets alpha / channels
    bic_margin: float = 10.0
    max_steps: int = 8
    region_alpha: float = 0.05
    # a residual RMS below this holds nothing to diagnose: no interferometer resolves 0.1 nm, and the
    # rounding of a noise-free simulation (--no-noise) would otherwise pass every test
    resolution_um: float = 1e-4
    # position-only physical effects (and the nuisance's position terms) may use at most this share of the
    # distinct positions: beyond it they fit any shape, and the free table is the honest description
    position_share: float = 0.5
    excluded: tuple[str, ...] = ()  # candidate types left out (the second pass without position-only effects)
    # AR(1) estimates of the channel's errors from earlier runs of the same machine, pooled with the run's own
    ar1_history: tuple[serial.Ar1Estimate, ...] = ()

    def to_dict(self) -> dict[str, Any]:
        return {"alpha_per_step": self.alpha, "channels": self.channels,
                "bonferroni": "alpha / (channels x candidates of the channel)",
                "bic_decrease_min": self.bic_margin, "cv": "grouped cross-validation RMSE must decrease",
                "ambiguity": f"another significant candidate within {self.bic_margin:g} of the best BIC that "
                             "adds nothing significant after it", "max_steps": self.max_steps,
                "resolution_um": self.resolution_um, "position_parameters_max_share": self.position_share,
                "cv_positions": "position-only effects must lower the RMSE of predicting held-out positions",
                "excluded": list(self.excluded),
                "backward": f"an added effect is dropped when not significant in the final model, swapped for a "
                            f"candidate of lower BIC in its place, or, when rivalled, replaced by the best pair of "
                            f"its {PAIR_TOP} best rivals that lowers the BIC by at least the margin with both "
                            "significant",
                "ar1_history": [e.to_dict() for e in self.ar1_history]}



POSITIONING_RULE = Rule(alpha=5e-3, bic_margin=6.0)
"""The rule of positioning runs (docs/diagnosis.md, "Detection and false alarms").  A one-parameter effect
of δ standard errors passes the F-test with probability ≈ Φ(δ − z_c), z_c = Φ⁻¹(1 − α / 2K) (K ≈ 10
candidates); at α = 0.001 (z_c = 3.9) and a BIC margin of 10 (z² ≥ 10 + ln n, z ≥ 3.9 at n = 210) both
criteria bind at once and a 5-SE effect passes 86 times in 100.  α = 0.005 (z_c = 3.5, Φ(1.5) = 0.93; the
family-wise false-alarm bound half the 1-in-100 target) with a margin of 6 (Kass & Raftery's "strong";
z ≥ 3.4 at n = 210, so the calibrated F-test binds), which also bounds the chance of naming the wrong one
of two correlated alternatives by Φ(−√6) = 0.007.  Straightness runs keep the stricter default: their
F-tests' tail is heavier than the bound (measured, same document)."""


def default_rule(kind: str) -> Rule:
    """The selection rule of a run of ``kind`` ("positioning" or "straightness")."""
    return POSITIONING_RULE if kind == "positioning" else Rule()

# -- noise --------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Noise:
    sigma_um: float
    dof: int
    source: str


def noise_estimate(obs: Observations, fit: Fit) -> Noise:
    """Pure error: the scatter of the residual within replicate groups, with the degrees of freedom
    the model's within-group columns use up; without replicates the residual standard error."""
    g = obs.replicate
    r = fit.residual
    counts = np.bincount(g)
    means = np.bincount(g, weights=r) / np.maximum(counts, 1)
    rss_pe = float(np.sum((r - means[g]) ** 2))
    within = 0
    nuis = obs.nuisance.shape[1]
    for col in fit.design[:, nuis:].T:
        cm = np.bincount(g, weights=col) / np.maximum(counts, 1)
        total = float(np.sum((col - col.mean()) ** 2))
        if total > 0 and float(np.sum((col - cm[g]) ** 2)) > 1e-9 * total:
            within += 1
    dof = int(np.sum(counts[counts > 0] - 1)) - within
    if dof >= 3:
        return Noise(math.sqrt(rss_pe / dof), dof, f"pure error of {obs.replicate_basis}")
    return Noise(fit.sigma_um, fit.n - fit.n_params, "residual standard error (no replicates in this run)")


# -- where the residual stands out ------------------------------------------------------------------------------
def _z_critical(groups: int, alpha: float) -> float:
    return float(stats.norm.isf(alpha / (2 * max(groups, 1))))


def disagreement(obs: Observations, residual: np.ndarray, sigma: float, alpha: float = 0.05) -> dict[str, Any]:
    """Mean residual by position, run / pass, direction and time; the groups whose mean stands out
    beyond the noise (|z| above the two-sided Bonferroni limit for the family at ``alpha``)."""
    v = obs.values
    groupings: dict[str, tuple[np.ndarray, list[str]]] = {}
    if obs.kind == "positioning":
        arrow = {1.0: "up", -1.0: "down"}
        keys = list(zip(v["target_index"], v["position_mm"], v["direction"], strict=True))
        groupings["position"] = _labelled(keys, lambda k: f"target {int(k[0])} ({k[1]:g} mm) {arrow[k[2]]}")
        groupings["run"] = _labelled(list(zip(v["run"], v["direction"], strict=True)),
                                     lambda k: f"run {int(k[0])} {arrow[k[1]]}")
        groupings["direction"] = _labelled(list(v["direction"]), lambda k: arrow[k])
    else:
        groupings["position"] = _labelled(list(v["station"]), lambda k: f"station {int(k)}")
        groupings["run"] = _labelled(list(v["pass"]), lambda k: "return pass" if k else "forward pass")
    if obs.has("time_min"):
        order = np.argsort(v["time_min"], kind="stable")
        bins = np.empty(obs.n, dtype=int)
        bins[order] = np.arange(obs.n) * min(obs.n, 8) // max(obs.n, 1)  # up to 8 groups, none empty
        t = v["time_min"]
        scale, unit = (1.0, "min") if t.max(initial=0) >= 2 else (60.0, "s")
        groupings["time"] = (bins, [f"{t[bins == b].min() * scale:.1f}-{t[bins == b].max() * scale:.1f} {unit}"
                                    for b in range(int(bins.max(initial=-1)) + 1)])
    out: dict[str, Any] = {"noise_um": sigma, "channel": obs.channel}
    for name, (ids, labels) in groupings.items():
        counts = np.bincount(ids)
        means = np.bincount(ids, weights=residual) / np.maximum(counts, 1)
        z = means / (sigma / np.sqrt(np.maximum(counts, 1))) if sigma > 0 else np.zeros_like(means)
        zc = _z_critical(len(labels), alpha)
        flagged = [{"group": labels[i], "n": int(counts[i]), "mean_um": float(means[i]), "z": float(z[i])}
                   for i in np.argsort(-np.abs(z)) if abs(z[i]) > zc]
        out[name] = {"z_limit": zc, "groups": len(labels), "max_abs_z": float(np.max(np.abs(z))) if z.size else 0.0,
                     "stand_out": flagged}
    return out


def _labelled(keys: list[Any], label: Any) -> tuple[np.ndarray, list[str]]:
    uniq: dict[Any, int] = {}
    ids = np.array([uniq.setdefault(k, len(uniq)) for k in keys], dtype=int)
    return ids, [label(k) for k in uniq]


# -- candidates -------------------------------------------------------------------------------------------------
MAX_PERIODIC = 2  # a screw lead and one more period; a longer Fourier series is a table, not a diagnosis
POSITIONING_CANDIDATES = ("linear_scale", "quadratic", "backlash", "periodic", "thermal_drift", "thermal_growth",
                          "abbe", "dead_path", "error_table")
NEEDS_TEXT = {"time_min": "no time_s recorded for every point", "index_change": "no air values recorded",
              "pitch_urad": "no pitch channel recorded", "yaw_urad": "no yaw channel recorded",
              "sensor_um": "no sensor channel", "dpitch_urad": "no pitch channel recorded"}


def candidate_effects(obs: Observations, model: tuple[Effect, ...]) -> tuple[list[Effect], dict[str, str]]:
    """The effects the diagnosis may add to ``model`` on this channel, and why others cannot be tested."""
    skipped: dict[str, str] = {}
    free_labels = {e.label for e in model if e.free and e.type != "periodic"}
    wanted: list[Effect] = []
    if obs.channel == "deviation":
        for t in POSITIONING_CANDIDATES:
            if t == "abbe":
                wanted += [Effect("abbe", {"offset_mm": 0.0, "channel": ch}, frozenset({"offset_mm"}))
                           for ch in ("pitch", "yaw")]
            elif t == "periodic":
                wanted.append(Effect("periodic", {"amplitude_um": 0.0, "wavelength_mm": None, "phase_rad": 0.0},
                                     frozenset({"amplitude_um", "wavelength_mm", "phase_rad"})))
            elif t == "error_table":
                nodes = tuple(float(p) for p in np.unique(obs.values["position_mm"]))
                if len(nodes) >= 3:
                    wanted.append(Effect(t, {"positions_mm": nodes, "error_um": tuple(0.0 for _ in nodes)},
                                         frozenset({"error_um"})))
            else:
                wanted.append(_linear(t))
    elif obs.channel == "height":
        wanted.append(_linear("sensor_drift"))
        if obs.nuisance_names[0].startswith("height_station"):
            why = "not visible without a reference profile: it is the same on the forward and the return pass"
            skipped.update({"sensor_gain": why, "lever_arm": why})
        else:
            wanted += [_linear("sensor_gain"), _linear("lever_arm")]
            st = obs.values["station"]
            nodes = tuple(float(obs.values["x_mm"][st == k].mean()) for k in np.unique(st))
            if len(nodes) >= 3 and all(b > a for a, b in zip(nodes, nodes[1:], strict=False)):
                wanted.append(Effect("profile_table", {"positions_mm": nodes, "height_um": tuple(0.0 for _ in nodes)},
                                     frozenset({"height_um"})))
    elif obs.channel == "lin":
        wanted.append(_linear("block_length"))
    out = []
    for e in wanted:
        if e.label in free_labels:
            continue
        if e.type == "periodic" and sum(m.type == "periodic" for m in model) >= MAX_PERIODIC:
            skipped["periodic"] = (f"the model has {MAX_PERIODIC} periodic effects; more structure along the "
                                   "travel is left to a free error table")
            continue
        missing = [k for k in basis.needs(e.type, e.variant) if not obs.has(k)]
        if missing:
            skipped[e.label] = NEEDS_TEXT.get(missing[0], f"{missing[0]} not recorded")
            continue
        out.append(e)
    return out, skipped


def _linear(t: str) -> Effect:
    return Effect(t, {basis.LINEAR[t][0]: 0.0}, frozenset({basis.LINEAR[t][0]}))


@dataclass(frozen=True)
class CandidateTest:
    """One candidate tested against the current model."""

    effect: Effect
    fit: Fit | None
    added: int
    delta_bic: float
    f_stat: float
    p_value: float
    p_threshold: float
    cv_before_um: float | None
    cv_after_um: float | None
    significant: bool
    look_elsewhere: float = 1.0
    ar1_phi: float = 0.0  # the AR(1) coefficient of the errors in time order the tests were whitened for
    # position-only physical candidates: the parameters of the position (with the model's) against the distinct
    # positions, and the RMSE of predicting held-out positions before and after
    position_budget: tuple[int, int] | None = None
    cv_positions_um: tuple[float | None, float | None] = (None, None)

    @property
    def label(self) -> str:
        return self.effect.label

    def evidence(self) -> dict[str, Any]:
        return {"delta_bic": self.delta_bic, "f": self.f_stat, "p_value": self.p_value,
                "p_threshold": self.p_threshold, "parameters_added": self.added,
                "wavelengths_scanned": self.look_elsewhere if self.look_elsewhere != 1.0 else None,
                "cv_rmse_before_um": self.cv_before_um, "cv_rmse_after_um": self.cv_after_um,
                "ar1_phi": self.ar1_phi,
                "position_parameters": self.position_budget[0] if self.position_budget else None,
                "positions": self.position_budget[1] if self.position_budget else None,
                "cv_positions_rmse_before_um": self.cv_positions_um[0],
                "cv_positions_rmse_after_um": self.cv_positions_um[1], "significant": self.significant}


POSITION_ONLY = ("linear_scale", "quadratic", "periodic")
"""Physical effects that are functions of the position alone: together they must leave most of the position
means' degrees of freedom to the noise (eight parameters reproduce eleven means, whatever their shape)."""


def position_parameters(obs: Observations, effects: tuple[Effect, ...]) -> int:
    """Parameters of the position-only physical effects of ``effects`` and of the nuisance's position terms."""
    k = sum(name in ("offset_um", "slope_um_per_m") for name in obs.nuisance_names)
    return k + sum(len(e.free) for e in effects if e.type in POSITION_ONLY)


def position_folds(obs: Observations) -> np.ndarray:
    """Cross-validation folds holding out whole positions (at most MAX_FOLDS, interleaved along the travel)."""
    return fold_ids(group_ids(obs.values["position_mm"]))


def test_candidate(obs: Observations, current: Fit, cand: Effect, k_tested: int, rule: Rule,
                   current_folds: FoldFits | None = None) -> CandidateTest | None:
    """Fit ``current`` + ``cand`` (the model's wavelengths kept); None when the candidate adds no parameter
    (it lies in the model's span).  ``current_folds``: the current model's cross-validation fits."""
    try:
        fit = fit_model(obs, (*current.effects, cand), refine={len(current.effects)}, standard_errors=False)
    except (ValueError, np.linalg.LinAlgError):
        return None
    added = fit.n_params - current.n_params - (1 if free_wavelength(cand) else 0)
    added_total = added + (1 if free_wavelength(cand) else 0)
    dof = obs.n - fit.n_params
    if added <= 0 or dof <= 0:
        return None
    n = obs.n
    phi, rss0, rss1 = whitened_rss(obs, current, fit, rule.ar1_history)
    dbic = bic(rss1, n, fit.n_params) - bic(rss0, n, current.n_params)
    f_stat = ((rss0 - rss1) / added_total) / (rss1 / dof) if rss1 > 0 else math.inf
    p = float(stats.f.sf(f_stat, added_total, dof))
    m_eff = 1.0
    if free_wavelength(cand):
        m_eff = wavelength_grid(obs.values["position_mm"])[1]
        p = float(-np.expm1(m_eff * np.log1p(-min(p, 1 - 1e-16))))
    threshold = rule.alpha / (max(k_tested, 1) * max(rule.channels, 1))
    before = current_folds or fold_fits(current.design, current.target, obs.folds)
    cv_before, cv_after = cv_rmse([before, fold_fits(fit.design, fit.target, obs.folds)])
    significant = (p < threshold and dbic <= -rule.bic_margin and current.rms_um > rule.resolution_um
                   and (cv_before is None or cv_after is None or cv_after < cv_before))
    budget: tuple[int, int] | None = None
    cv_pos: list[float | None] = [None, None]
    if cand.type in POSITION_ONLY and obs.has("position_mm"):
        # parameters against the position degrees of freedom, and a test on held-out positions: a combination of
        # scale and waves can reproduce a handful of position means whatever their shape (a step, a joint)
        budget = (position_parameters(obs, fit.effects), len(np.unique(obs.values["position_mm"])))
        folds = position_folds(obs)
        cv_pos = cv_rmse([fold_fits(current.design, current.target, folds), fold_fits(fit.design, fit.target, folds)])
        significant = (significant and budget[0] <= budget[1] * rule.position_share
                       and (None in cv_pos or cv_pos[1] < cv_pos[0]))  # type: ignore[operator]
    return CandidateTest(fit.effects[-1], fit, added_total, dbic, f_stat, p, threshold, cv_before, cv_after,
                         significant, m_eff, phi, budget, (cv_pos[0], cv_pos[1]))


def whitened_rss(obs: Observations, smaller: Fit, larger: Fit, history: tuple[serial.Ar1Estimate, ...] = ()
                 ) -> tuple[float, float, float]:
    """(φ, RSS of ``smaller``, RSS of ``larger``) after the Prais–Winsten transform for AR(1) errors in
    time order (serial.py), φ estimated from the larger model's residual (it holds under both hypotheses:
    an effect missing from the smaller model would pass for correlation in its residual); φ = 0: the
    ordinary sums.  Both models are fitted to the same observations, so the nested comparison (F-test,
    BIC) is the generalised least-squares one.  ``history``: estimates from earlier runs, pooled with it."""
    order = serial.time_order(obs.values, obs.n)
    phi = serial.ar1_coefficient(larger.residual[order], orthonormal_basis(larger.design)[order], history,
                                 serial.point_interval_s(obs.values.get("time_min")))
    if phi == 0.0:
        return 0.0, smaller.rss, larger.rss
    rss = [solve(serial.prais_winsten(f.design, order, phi), serial.prais_winsten(f.target, order, phi))[1]
           for f in (smaller, larger)]
    return phi, rss[0], rss[1]


# -- the loop ---------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Step:
    """One effect added to the model, with the evidence and the fit after it."""

    test: CandidateTest
    fit: Fit
    noise: Noise
    tested: tuple[CandidateTest, ...]
    ambiguous_with: tuple[str, ...] = ()
    # the effect tested again in the final model, the others in (what the backward pass keeps it on):
    # a step can be below the rule on its own when effects are significant only together
    in_final: CandidateTest | None = None
    alternatives: tuple[Effect, ...] = ()  # the ambiguous candidates as fitted in its place
    implausible: str = ""  # why its fitted value is physically implausible (then it is not named)

    @property
    def effect(self) -> Effect:
        """The effect as fitted in the model after this step."""
        return self.fit.effects[-1] if self.fit.effects else self.test.effect


@dataclass(frozen=True)
class ChannelDiagnosis:
    obs: Observations
    model: tuple[Effect, ...]
    baseline: Fit
    baseline_noise: Noise
    steps: tuple[Step, ...]
    final: Fit
    noise: Noise
    disagreement: dict[str, Any]
    ambiguous: tuple[tuple[str, ...], ...]
    not_testable: dict[str, str]
    last_round: tuple[CandidateTest, ...]
    rule: Rule = field(default_factory=Rule)
    structure: dict[str, Any] = field(default_factory=dict)  # what the final residual still holds

    @property
    def position_unexplained(self) -> bool:
        """The final residual still varies with the position beyond the noise: the position-only effects
        added describe part of something the library does not hold, and are not named."""
        return bool(self.structure.get("position", {}).get("structured"))

    def is_named(self, step: Step) -> bool:
        return not (step.ambiguous_with or step.implausible
                    or (self.position_unexplained and step.test.effect.type in POSITION_ONLY))

    @property
    def named(self) -> list[str]:
        return [s.test.effect.type for s in self.steps if self.is_named(s)]


def diagnose_channel(obs: Observations, model: tuple[Effect, ...] | list[Effect], rule: Rule | None = None
                     ) -> ChannelDiagnosis:
    """Run the diagnosis on one channel (``model``: the effects that act on it).

    Forward selection adds the best significant candidate until none is left; a backward pass
    then drops an added effect that is no longer significant in the final model, or swaps it for
    a candidate that explains more in its place (an early step decided while larger effects were
    still unmodelled); the steps are then told again in order of evidence, and every added effect
    is checked for a candidate it cannot be told apart from, in the final model.
    """
    rule = rule or Rule()
    model = tuple(model)
    for e in model:
        missing = [k for k in basis.needs(e.type, e.variant) if not obs.has(k)]
        if missing:
            raise ValueError(f"the model's {e.label} cannot be evaluated on this run "
                             f"({NEEDS_TEXT.get(missing[0], f'{missing[0]} not recorded')}); take it out of the model")
    baseline = fit_model(obs, model, ar1_history=rule.ar1_history)
    base_noise = noise_estimate(obs, baseline)
    regions = disagreement(obs, baseline.residual, base_noise.sigma_um, rule.region_alpha)
    not_testable: dict[str, str] = {}
    steps, last = _forward(obs, baseline, rule, not_testable)
    final = steps[-1].fit if steps else baseline
    refined = _backward(obs, final, len(model), rule)
    if refined is not None:
        chosen = Counter(e.label for e in refined.effects[len(model):])  # two periodic effects count twice
        steps, last = _forward(obs, baseline, rule, not_testable, allowed=chosen)
        final = steps[-1].fit if steps else baseline
    ambiguous: list[tuple[str, ...]] = []
    alike_of: dict[int, tuple[str, ...]] = {}
    alternatives: dict[int, tuple[Effect, ...]] = {}
    in_final: dict[int, CandidateTest] = {}
    for j, effect in enumerate(final.effects):
        if effect.free:
            alike, own = _indistinguishable(obs, final, j, rule)
            if own is not None:
                in_final[j] = own
            if alike:
                alike_of[j] = tuple(a.label for a in alike)
                alternatives[j] = tuple(alike)
                group = tuple(sorted({effect.type, *(a.type for a in alike)}))
                if group not in ambiguous:
                    ambiguous.append(group)
    told = [Step(s.test, s.fit, s.noise, s.tested, alike_of.get(len(model) + i, ()), in_final.get(len(model) + i),
                 alternatives.get(len(model) + i, ()), implausible(final.effects[len(model) + i], obs))
            for i, s in enumerate(steps)]
    noise = noise_estimate(obs, final)
    out = ChannelDiagnosis(obs, model, baseline, base_noise, tuple(told), final, noise, regions, tuple(ambiguous),
                           not_testable, last, rule,
                           residual_structure(obs, final, noise) if final.rms_um > rule.resolution_um else {})
    if out.position_unexplained and any(s.test.effect.type in POSITION_ONLY for s in told):
        # scale and waves leave structure along the travel: the free table (tried once no physical effect is
        # significant) may describe it instead; it is preferred when it leaves none
        alt = diagnose_channel(obs, model, replace(rule, excluded=POSITION_ONLY))
        if not alt.position_unexplained and any(s.test.effect.type in CATCH_ALL for s in alt.steps):
            return alt
    return out


STRUCTURE_ALPHA = 1e-3


def residual_structure(obs: Observations, fit: Fit, noise: Noise, alpha: float = STRUCTURE_ALPHA) -> dict[str, Any]:
    """Is the residual white?  In time order: the Ljung–Box test (10 lags) and the AR(1) coefficient; along the
    position: the lack-of-fit F-test of the residual against the scatter within the replicate groups (same
    position), and where the mean residual changes most between adjacent positions."""
    order = serial.time_order(obs.values, obs.n)
    r = fit.residual[order]
    q, p, lags = serial.ljung_box(r, 10)
    out: dict[str, Any] = {"alpha": alpha, "time": {
        "order": "time" if obs.has("time_min") else "acquisition", "ljung_box_q": q, "lags": lags, "p_value": p,
        "ar1_phi": serial.ar1_coefficient(r, orthonormal_basis(fit.design)[order]), "structured": p < alpha}}
    key = "position_mm" if obs.has("position_mm") else "x_mm"
    dof_lof = obs.n - fit.n_params - noise.dof
    if not noise.source.startswith("pure error") or dof_lof <= 0 or not obs.has(key) or noise.sigma_um <= 0:
        return out
    ss_pe = noise.sigma_um**2 * noise.dof
    f = ((fit.rss - ss_pe) / dof_lof) / noise.sigma_um**2
    p = float(stats.f.sf(f, dof_lof, noise.dof))
    pos, inv = np.unique(np.round(obs.values[key], 6), return_inverse=True)
    counts = np.bincount(inv).astype(float)
    means = np.bincount(inv, weights=fit.residual) / counts
    where: dict[str, Any] = {}
    if len(pos) >= 2:
        z = np.diff(means) / (noise.sigma_um * np.sqrt(1 / counts[1:] + 1 / counts[:-1]))
        k = int(np.argmax(np.abs(z)))
        # two-sided, Bonferroni over the adjacent pairs (conservative: the fit only shrinks the residual)
        p_step = min(1.0, float(2 * stats.norm.sf(abs(z[k]))) * len(z))
        where = {"at_mm": float((pos[k] + pos[k + 1]) / 2), "between_mm": [float(pos[k]), float(pos[k + 1])],
                 "change_um": float(means[k + 1] - means[k]), "z": float(z[k]), "p_value": p_step}
    structured = p < alpha or where.get("p_value", 1.0) < alpha
    out["position"] = {"lack_of_fit_f": f, "dof": [dof_lof, noise.dof], "p_value": p, "structured": structured,
                       "largest_change": where}
    return out


CATCH_ALL = ("error_table", "profile_table")
"""Free tables: they fit any position-dependent error, so they are tried only when no physical effect
with few parameters is significant (and a candidate table around a named effect is not its rival)."""


def _round(obs: Observations, current: Fit, rule: Rule, not_testable: dict[str, str],
           catch_all: bool | str = "last") -> list[CandidateTest]:
    """Every candidate tested against ``current``, best (lowest BIC) first; the free tables too when
    ``catch_all`` is True, or with ``"last"`` when no other candidate is significant."""
    cands, skipped = candidate_effects(obs, current.effects)
    cands = [c for c in cands if c.type not in rule.excluded]
    not_testable.update(skipped)
    k = len(cands)  # the Bonferroni family counts every candidate, tested or not
    folds = fold_fits(current.design, current.target, obs.folds)

    def run(group: list[Effect]) -> list[CandidateTest]:
        out = [t for t in (test_candidate(obs, current, c, k, rule, folds) for c in group) if t is not None]
        for c in group:
            if not any(t.effect.label == c.label for t in out):
                not_testable.setdefault(c.label, "no variation beyond what the model already fits on this run")
        return out

    tests = run([c for c in cands if c.type not in CATCH_ALL])
    if catch_all is True or (catch_all == "last" and not any(t.significant for t in tests)):
        tests += run([c for c in cands if c.type in CATCH_ALL])
    return sorted(tests, key=lambda t: t.delta_bic)


def _pick(tests: list[CandidateTest]) -> CandidateTest | None:
    """The best significant candidate, a physical effect before a free table."""
    winners = [t for t in tests if t.significant]
    return next((t for t in winners if t.effect.type not in CATCH_ALL), winners[0] if winners else None)


def _forward(obs: Observations, start: Fit, rule: Rule, not_testable: dict[str, str],
             allowed: Counter[str] | None = None) -> tuple[list[Step], tuple[CandidateTest, ...]]:
    """Add the best significant candidate until none is left; with ``allowed`` (the steps told again after
    the backward pass) those first, best first, then any other significant one: the loop ends only when
    nothing significant is left (or after ``rule.max_steps`` steps beyond the ones told again)."""
    steps: list[Step] = []
    current = start
    tested: list[CandidateTest] = []
    told = Counter() if allowed is None else allowed
    for _ in range(rule.max_steps + told.total()):
        left = told - Counter(e.label for e in current.effects[len(start.effects):])
        if left:
            tested = _round(obs, current, rule, not_testable, catch_all=any(lb in CATCH_ALL for lb in left))
            pool = [t for t in tested if t.effect.label in left]
            # the significant ones first: each step's evidence is then that of a step the rule takes
            best = _pick(pool) or next((t for t in pool if t.effect.type not in CATCH_ALL), pool[0] if pool else None)
            if best is None:  # cannot be told again (no longer testable here): carry on with the rule
                told = Counter()
                continue
        else:
            tested = _round(obs, current, rule, not_testable)
            best = _pick(tested)
            if best is None:
                break
        assert best.fit is not None
        # all wavelengths refined; standard errors for the AR(1) errors the tests were whitened for
        current = fit_model(obs, best.fit.effects, ar1_history=rule.ar1_history)
        steps.append(Step(best, current, noise_estimate(obs, current), tuple(tested)))
    return steps, tuple(tested)


def _without(obs: Observations, fit: Fit, j: int) -> Fit:
    return fit_model(obs, fit.effects[:j] + fit.effects[j + 1:], standard_errors=False)


def _backward(obs: Observations, final: Fit, n_model: int, rule: Rule) -> Fit | None:
    """Drop added effects that are not significant in the final model, swap one for a better candidate;
    the refined fit, or None when nothing changed."""
    current, changed = final, False
    for _ in range(2 * rule.max_steps):
        for j in range(n_model, len(current.effects)):
            reduced = _without(obs, current, j)
            table = current.effects[j].type in CATCH_ALL
            tests = _round(obs, reduced, rule, {}, catch_all=table)
            own = next((t for t in tests if t.effect.label == current.effects[j].label), None)
            if own is None or not own.significant:
                current, changed = reduced, True
                break
            best = _pick(tests) if not table else next(t for t in tests if t.significant)
            assert best is not None
            if best.effect.label != own.effect.label and best.delta_bic < own.delta_bic:
                assert best.fit is not None
                current, changed = best.fit, True
                break
            pair = None if table else _pair_in_place(obs, current, reduced, own, tests, rule)
            if pair is not None:
                current, changed = pair, True
                break
        else:
            return current if changed else None
    return current


PAIR_TOP = 4
"""The pairs tried in place of an added effect are those among its ``PAIR_TOP`` best rivals (by their BIC in its
place): 6 fits per added effect, where all pairs of the ~10 candidates would take 45."""


def _pair_in_place(obs: Observations, current: Fit, reduced: Fit, own: CandidateTest, tests: list[CandidateTest],
                   rule: Rule) -> Fit | None:
    """Two candidates in place of an added effect: the forward selection adds one effect at a time, so one
    whose signature resembles the sum of two others (a thermal growth P·t for a sag P² and a dead path whose
    air index rises in time) can beat either of them alone and leave neither significant after it.  When the
    effect is rivalled (another candidate is significant in its place), the pairs among its best ``PAIR_TOP``
    rivals are fitted in its place; the best pair is taken when it lowers the BIC of the model by at least the
    rule's margin (the whitened sums, φ from the pair's residual, as every test) and each of the two is
    significant with the other in the model (the rule's test, as the backward pass asks of every added effect).
    The fit with the pair, or None."""
    rivals = [t for t in tests if t is not own and t.effect.type not in CATCH_ALL and t.fit is not None
              and t.delta_bic < 0]
    if not any(t.significant for t in rivals):
        return None
    rivals = rivals[:PAIR_TOP]  # tests are sorted by their BIC, best first
    periodic_left = MAX_PERIODIC - sum(e.type == "periodic" for e in reduced.effects)
    n = obs.n
    tried: list[tuple[float, Fit, int]] = []
    for i, a in enumerate(rivals):
        for b in rivals[i + 1:]:
            if (a.effect.type == "periodic") + (b.effect.type == "periodic") > periodic_left:
                continue
            base = len(reduced.effects)
            try:
                fit = fit_model(obs, (*reduced.effects, a.effect, b.effect), refine={base, base + 1},
                                standard_errors=False)
            except (ValueError, np.linalg.LinAlgError):
                continue
            _, rss_now, rss_pair = whitened_rss(obs, current, fit, rule.ar1_history)
            gain = bic(rss_pair, n, fit.n_params) - bic(rss_now, n, current.n_params)
            if gain <= -rule.bic_margin:
                tried.append((gain, fit, base))
    for _, fit, base in sorted(tried, key=lambda g: g[0]):
        if all(_significant_in(obs, fit, base + m, rule) for m in (0, 1)):
            return fit
    return None


def _significant_in(obs: Observations, fit: Fit, j: int, rule: Rule) -> bool:
    """The ``j``-th effect of ``fit`` passes the rule tested in its place, the other effects in."""
    reduced = _without(obs, fit, j)
    cands = [c for c in candidate_effects(obs, reduced.effects)[0] if c.type not in rule.excluded]
    fresh = Effect(fit.effects[j].type, _zeroed(fit.effects[j]), fit.effects[j].free)
    test = test_candidate(obs, reduced, fresh, len(cands), rule)
    return test is not None and test.significant


def _indistinguishable(obs: Observations, final: Fit, j: int, rule: Rule
                       ) -> tuple[list[Effect], CandidateTest | None]:
    """Candidates that, in place of the ``j``-th effect of the final model, are significant and come within
    the BIC margin of it, and add nothing significant once it is in the model; and the effect's own test
    there (None when it cannot be tested in its place).  A candidate that strictly
    contains the effect (a free table around a linear scale) is not an alternative: parsimony prefers the
    effect; the reverse (a linear scale inside a free table of the model) is ambiguous."""
    reduced = _without(obs, final, j)
    tests = _round(obs, reduced, rule, {}, catch_all=final.effects[j].type in CATCH_ALL)
    own = next((t for t in tests if t.effect.label == final.effects[j].label), None)
    if own is None:
        return [], None
    k = len(candidate_effects(obs, reduced.effects)[0])
    mine = basis.columns(final.effects[j], obs).matrix
    out = []
    for other in tests:
        if other is own or not other.significant or other.delta_bic - own.delta_bic >= rule.bic_margin:
            continue
        theirs = basis.columns(other.effect, obs).matrix  # a strictly more general candidate: parsimony
        if _inside(mine, theirs, obs.nuisance) and not _inside(theirs, mine, obs.nuisance):
            continue
        fresh = Effect(other.effect.type, _zeroed(other.effect), other.effect.free)
        again = test_candidate(obs, final, fresh, k, rule)
        if again is None or not again.significant:
            out.append(other.effect)
    return out, own


def _zeroed(e: Effect) -> dict[str, Any]:
    params = dict(e.params)
    if e.type == "periodic":
        params["wavelength_mm"] = None
    return params


NESTED_R2 = 0.999


def _inside(cols: np.ndarray, span: np.ndarray, nuisance: np.ndarray) -> bool:
    """Every column of ``cols`` lies in the span of ``span`` and the nuisance (R² ≥ 0.999 of what the
    nuisance leaves of it)."""
    def rest(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        bs = b / np.maximum(np.linalg.norm(b, axis=0), 1e-300)
        return a - bs @ np.linalg.lstsq(bs, a, rcond=None)[0]

    base = np.sum(rest(cols, nuisance) ** 2, axis=0)
    left = np.sum(rest(cols, np.column_stack([nuisance, span])) ** 2, axis=0)
    ok = base > 0
    return bool(np.all(left[ok] <= (1 - NESTED_R2) * base[ok]))
