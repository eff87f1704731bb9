"""The HTML report of a diagnosis (``guideway diagnose --report FILE``): the gap before and after
every added effect, a plot per step, the evidence of every candidate, the regions that stand
out, what is ambiguous, and the final model file."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

from processing.diagnosis.observations import Observations  # noqa: E402
from processing.diagnosis.select import CandidateTest, ChannelDiagnosis  # noqa: E402

from ..report.build import tool_version  # noqa: E402
from ..report.html import HtmlPage, figure_png, write_page  # noqa: E402
from .diagnose import Diagnosis, format_params  # noqa: E402
from .remains import not_named_because, remains  # noqa: E402

CHANNEL_TEXT = {"deviation": "positioning deviation x = reading − target (µm)",
                "height": "surface height of every point (µm)",
                "lin": "interferometer X channel lin_um (µm)"}


def _x(obs: Observations) -> tuple[np.ndarray, str]:
    if obs.kind == "positioning":
        return obs.values["position_mm"], "target position (mm)"
    return obs.values["x_mm"], "x (mm)"


def _colours(obs: Observations) -> tuple[np.ndarray, dict[float, tuple[str, str]]]:
    if obs.kind == "positioning":
        return obs.values["direction"], {1.0: ("tab:blue", "↑ approach"), -1.0: ("tab:red", "↓ approach")}
    return obs.values["pass"], {0.0: ("tab:blue", "forward pass"), 1.0: ("tab:red", "return pass")}


def residual_figure(obs: Observations, before: np.ndarray | None, after: np.ndarray, title: str) -> Figure:
    """Residual against position and against time; ``before`` (grey) is the residual before the step."""
    has_time = obs.has("time_min")
    fig, axes = plt.subplots(1, 2 if has_time else 1, figsize=(10, 3.6), dpi=100, squeeze=False)
    x, xlabel = _x(obs)
    key, colours = _colours(obs)
    for ax, xs, label in zip(axes[0], (x, obs.values.get("time_min")), (xlabel, "time since the start (min)"),
                             strict=False):
        if before is not None:
            ax.plot(xs, before, ".", color="0.7", ms=3, label="before")
        for value, (colour, name) in colours.items():
            sel = key == value
            if sel.any():
                ax.plot(xs[sel], after[sel], ".", color=colour, ms=4, label=name)
        ax.axhline(0.0, color="k", lw=0.6)
        ax.set_xlabel(label)
        ax.set_ylabel("residual (µm)")
        ax.grid(True, alpha=0.3)
    axes[0][0].legend(fontsize=7, loc="best")
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return fig


def gap_figure(ch: ChannelDiagnosis) -> Figure:
    """RMS and maximum residual after each stage, with the noise level."""
    labels = ["model"] + [f"+ {s.test.effect.label}" for s in ch.steps]
    fits = [ch.baseline] + [s.fit for s in ch.steps]
    fig, ax = plt.subplots(figsize=(7, 3.2), dpi=100)
    pos = np.arange(len(fits))
    ax.bar(pos - 0.2, [f.rms_um for f in fits], 0.4, label="RMS")
    ax.bar(pos + 0.2, [f.max_um for f in fits], 0.4, label="max |r|")
    ax.axhline(ch.noise.sigma_um, color="k", ls="--", lw=0.8, label="noise")
    ax.set_xticks(pos, labels, fontsize=8)
    ax.set_ylabel("µm")
    ax.set_title(f"{ch.obs.channel} channel: the gap after each step", fontsize=10)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def _evidence_rows(tests: tuple[CandidateTest, ...]) -> list[tuple[Any, ...]]:
    return [(t.effect.label, t.added, t.delta_bic, t.p_value, t.p_threshold, t.cv_before_um, t.cv_after_um,
             "yes" if t.significant else "no") for t in tests]


EVIDENCE_HEADER = ("candidate", "parameters", "ΔBIC", "p", "p limit", "CV RMSE before (µm)", "CV RMSE after (µm)",
                   "significant")


def channel_sections(page: HtmlPage, ch: ChannelDiagnosis) -> None:
    o = ch.obs
    page.heading(f"{o.channel} channel: {CHANNEL_TEXT.get(o.channel, o.channel)}")
    page.key_values([
        ("points", o.n), ("nuisance fitted always", ", ".join(o.nuisance_names[:4]) +
                          (f" … ({len(o.nuisance_names)})" if len(o.nuisance_names) > 4 else "")),
        ("noise (model)", f"{ch.baseline_noise.sigma_um:.4f} µm, {ch.baseline_noise.source}"),
        ("noise (final)", f"{ch.noise.sigma_um:.4f} µm ({ch.noise.dof} degrees of freedom)"),
        ("cross-validation folds", o.fold_basis),
    ], digits=4)
    rows = [("model", "", ch.baseline.rms_um, ch.baseline.max_um, ch.baseline_noise.sigma_um)]
    rows += [(f"+ {s.test.effect.label}", _verdict(ch, s), s.fit.rms_um, s.fit.max_um,
              s.noise.sigma_um) for s in ch.steps]
    page.table(("stage", "", "RMS (µm)", "max |r| (µm)", "noise (µm)"), rows, digits=4, text_columns=(0, 1))
    page.image(figure_png(gap_figure(ch)), "RMS and maximum residual after each added effect; dashed: the noise "
                                           "estimated from the run.")
    page.heading("Where the model and the run disagree", 3)
    stand = [(region, g["group"], g["n"], g["mean_um"], g["z"]) for region, info in ch.disagreement.items()
             if isinstance(info, dict) for g in info.get("stand_out", [])[:8]]
    if stand:
        page.table(("by", "group", "points", "mean residual (µm)", "z"), stand, digits=3, text_columns=(0, 1))
        page.paragraph("Groups whose mean residual stands out beyond the noise: |z| above the two-sided "
                       "Bonferroni limit for the family at 5 % (z = mean / (noise / √n)).", "note")
    else:
        page.paragraph("No group of points stands out beyond the noise.")
    page.image(figure_png(residual_figure(o, None, ch.baseline.residual, "Residual under the model")),
               "Residual of the run under the model (free parameters fitted).")
    before = ch.baseline.residual
    for i, s in enumerate(ch.steps, start=1):
        why = not_named_because(ch, s)
        verdict = f"{why}, not named" if why else "named"
        page.heading(f"Step {i}: + {s.test.effect.label} ({verdict})", 3)
        under = (f", for errors correlated in time, AR(1) coefficient {s.fit.se_ar1_phi:.2f}"
                 if s.fit.se_ar1_phi > 0 else "")
        page.paragraph(f"{format_params(s.effect, s.fit.se[-1])} (± one standard error{under}). RMS "
                       f"{_rms(before):.4f} → {s.fit.rms_um:.4f} µm, max {np.max(np.abs(before)):.4f} → "
                       f"{s.fit.max_um:.4f} µm.")
        page.image(figure_png(residual_figure(o, before, s.fit.residual, f"Step {i}: + {s.test.effect.label}")),
                   f"Residual before (grey) and after adding {s.test.effect.label} (coloured).")
        if not s.test.significant and s.in_final is not None:
            page.paragraph(f"Below the rule on its own at this step; significant only with the later steps: in the "
                           f"final model ΔBIC {s.in_final.delta_bic:.1f}, p {s.in_final.p_value:.2g} (limit "
                           f"{s.in_final.p_threshold:.2g}).", "note")
        page.table(EVIDENCE_HEADER, _evidence_rows(s.tested), digits=4, text_columns=(0, 7))
        before = s.fit.residual
    page.heading("What remains", 3)
    left = remains(ch)
    white = not any(v.get("structured") for v in ch.structure.values() if isinstance(v, dict))
    page.paragraph("The final residual is white: no structure in time order or along the position (α = 0.001)."
                   if white else "The final residual is not white:")
    for sentence in left:
        page.paragraph(sentence, "note")
    page.heading("Candidates after the last step", 3)
    if ch.last_round:
        page.table(EVIDENCE_HEADER, _evidence_rows(ch.last_round), digits=4, text_columns=(0, 7))
    if ch.not_testable:
        page.table(("effect", "not tested because"), sorted(ch.not_testable.items()), text_columns=(0, 1))


def _rms(r: np.ndarray) -> float:
    return float(np.sqrt(np.mean(r**2))) if r.size else float("nan")


def render_diagnosis(d: Diagnosis) -> str:
    page = HtmlPage(f"guideway diagnosis — {d.run.meta.get('machine') or 'run'} {d.run.path.name}")
    page.key_values([
        ("run", str(d.run.path)), ("kind", d.run.kind), ("model", d.model.source),
        ("named", ", ".join(d.named) or "nothing significant is missing"),
        ("ambiguous", "; ".join(" / ".join(g) for g in d.ambiguous) or "—"),
    ])
    for note in d.notes:
        page.paragraph(f"Note: {note}", "note")
    rule = d.primary.rule
    page.paragraph(f"Selection rule (docs/diagnosis.md): a candidate is significant when its F-test p is below "
                   f"α/(C·K) (α = {rule.alpha:g}, C = {rule.channels} channel(s) of the run, K = candidates of the "
                   f"channel; a searched periodic wavelength corrected for the wavelengths scanned), it lowers BIC by "
                   f"at least {rule.bic_margin:g} and it lowers the grouped cross-validation RMSE. The best is "
                   "named unless another candidate explains the same residual as well (then both are reported as "
                   "ambiguous); a named effect is significant in the final model, the others in.", "note")
    for ch in d.channels:
        channel_sections(page, ch)
    page.heading("Final model")
    page.preformatted(d.model_file_text())
    page.paragraph(f"Produced by guideway {tool_version()}.", "note footer")
    return page.render()


def write_diagnosis_report(d: Diagnosis, path: Path | str) -> Path:
    return write_page(path, render_diagnosis(d), option="--report", example="diagnosis.html")


def _verdict(ch: ChannelDiagnosis, step: Any) -> str:
    return "implausible" if step.implausible else "ambiguous" if step.ambiguous_with else \
        "named" if ch.is_named(step) else "not named"
