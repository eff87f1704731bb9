"""What the final model leaves in a channel, said in words: structure along the travel that no effect
of the library explains (and where), and correlation in time (docs/diagnosis.md, "What remains")."""

from __future__ import annotations

from processing.diagnosis.select import POSITION_ONLY, ChannelDiagnosis, Step, disagreement


def remains(ch: ChannelDiagnosis) -> list[str]:
    """One sentence per kind of structure the final residual of ``ch`` still holds (empty: it is white)."""
    out = []
    pos = ch.structure.get("position", {})
    where = pos.get("largest_change") or {}
    if pos.get("structured") and where:
        partial = sorted({s.test.effect.type for s in ch.steps if s.test.effect.type in POSITION_ONLY})
        out.append(f"unexplained structure at P ≈ {where['at_mm']:.0f} mm: the mean residual changes by "
                   f"{where['change_um']:+.3f} um between {where['between_mm'][0]:g} and {where['between_mm'][1]:g} mm "
                   f"(z {where['z']:+.1f}; lack of fit p {pos['p_value']:.2g}); no effect of the library explains it "
                   "(a scale joint, a step, a local defect?)"
                   + (f"; {', '.join(partial)} describe part of it and are not named" if partial else ""))
    elif where and any(s.test.effect.type in ("error_table", "profile_table") and ch.is_named(s) for s in ch.steps):
        out.append(f"the free table describes the structure along the travel, no physical effect of the library does; "
                   f"before it, the largest change between adjacent positions was at P ≈ {_table_step_mm(ch):.0f} mm")
    t = ch.structure.get("time", {})
    if t.get("structured"):
        late = disagreement(ch.obs, ch.final.residual, ch.noise.sigma_um).get("time", {}).get("stand_out", [])
        groups = ", ".join(f"{g['group']} {g['mean_um']:+.3f} um (z {g['z']:+.1f})" for g in late[:3])
        out.append(f"the residual is correlated in {t['order']} order (AR(1) coefficient {t['ar1_phi']:.2f}, Ljung-Box "
                   f"Q {t['ljung_box_q']:.1f} on {t['lags']} lags, p {t['p_value']:.2g})"
                   + (f", time groups standing out: {groups}" if groups else "")
                   + ": correlated noise (a slow wander of the air or the temperature) or a slow effect outside the "
                   "library; the significance tests are whitened for it, and the noise estimate includes it")
    return out


def _table_step_mm(ch: ChannelDiagnosis) -> float:
    """Where the residual before the table changed most between adjacent positions."""
    import numpy as np

    from processing.diagnosis.select import residual_structure

    i = next(i for i, s in enumerate(ch.steps) if s.test.effect.type in ("error_table", "profile_table"))
    before = ch.steps[i - 1].fit if i else ch.baseline
    noise = ch.steps[i - 1].noise if i else ch.baseline_noise
    where = residual_structure(ch.obs, before, noise).get("position", {}).get("largest_change") or {}
    return float(where.get("at_mm", np.nan))


def not_named_because(ch: ChannelDiagnosis, step: Step) -> str | None:
    """Why a step's effect is in the final model but not named (None: it is named)."""
    if step.implausible:
        return f"implausible: {step.implausible}"
    if step.ambiguous_with:
        return f"ambiguous with {', '.join(step.ambiguous_with)}"
    if not ch.is_named(step):
        return "structure along the travel remains that the library does not explain; this effect describes part of it"
    return None
