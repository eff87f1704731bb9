"""Report sections of a straightness run: summary, profile plot, wavelengths, return
pass, uncertainty and the per-station table.  Heights and deviations in µm, x in mm."""

from __future__ import annotations

from typing import Any

from processing.straightness import StraightnessResult
from processing.uncertainty import K

from ..evaluation.straightness import StraightnessEvaluation, datum_text
from ..results.straightness import LINE_LABELS, profile_figure
from .common import verdict_section
from .html import HtmlPage, figure_png

METHOD_LABELS = {
    "exact": "exact (rigid-body transform of the block; docs/conventions.md)",
    "first-order": "first-order (small-angle) formula",
    "patent": "patent formula (seed 001)",
}


def line_label(name: str) -> str:
    return LINE_LABELS.get(name, name.replace("_", " ") + " line")


def straightness_sections(page: HtmlPage, evaluation: StraightnessEvaluation) -> None:
    r = evaluation.result
    summary_section(page, evaluation)
    run_events_section(page, evaluation.run.meta)
    page.heading("Profile")
    page.image(figure_png(profile_figure(r)),
               "Top: base-surface profile (+Y height) with the end-point, least-squares and minimum-zone "
               f"reference lines and the expanded-uncertainty band U (k = {K:g}). Bottom: deviation from the "
               "minimum-zone line with the zone.")
    wavelength_section(page, r)
    return_pass_section(page, r)
    uncertainty_section(page, r)
    stations_section(page, r)


def straightness_headline(page: HtmlPage, evaluation: StraightnessEvaluation) -> None:
    """The result in one line (the tolerance's reference line, else minimum zone) and the verdict."""
    r = evaluation.result
    tol = ((evaluation.run.meta.get("setup") or {}).get("tolerance") or {})
    line = tol.get("reference_line", "minimum_zone") if isinstance(tol, dict) else "minimum_zone"
    fit = r.lines.get(line)
    page.heading("Result")
    if fit is None:
        page.paragraph("No straightness evaluated.", "note")
        return
    mc = r.uncertainty.to_dict().get("straightness", {}) if r.uncertainty is not None else {}
    unc = f" ± {mc[line]:.3f} µm (k = {K:g})" if line in mc else ""
    travel = float(r.profile["x_mm"].iloc[-1] - r.profile["x_mm"].iloc[0]) if len(r.profile) else 0.0
    page.paragraph(f"Straightness {fit.straightness_um:.3f} µm{unc} against the {line_label(line)}, "
                   f"over {travel:g} mm", "headline")
    verdict_section(page, evaluation.verdict, "straightness_um, reference_line")


def summary_section(page: HtmlPage, evaluation: StraightnessEvaluation) -> None:
    r = evaluation.result
    prof = r.profile
    setup = evaluation.run.meta.get("setup") or {}
    page.heading("Straightness")
    travel = float(prof["x_mm"].iloc[-1] - prof["x_mm"].iloc[0]) if len(prof) else 0.0
    page.key_values([
        ("stations evaluated", len(prof)),
        ("travel (mm)", travel),
        ("gauge block length (mm)", setup.get("block_length_mm", "—")),
        ("decoupling method", METHOD_LABELS.get(r.method, r.method)),
        *([("datum angles (laser frame)", datum_text(r))] if r.datum is not None else []),
    ], digits=3)
    mc = r.uncertainty.to_dict().get("straightness", {}) if r.uncertainty is not None else {}
    interval = (r.uncertainty.to_dict().get("straightness_interval_95", {})
                if r.uncertainty is not None else {})
    rows = []
    for name, fit in r.lines.items():
        lo_hi = interval.get(name)
        rows.append((line_label(name), fit.straightness_um, mc.get(name),
                     f"{lo_hi[0]:.3f} … {lo_hi[1]:.3f}" if lo_hi else "—",
                     fit.slope_um_per_mm * 1000.0, fit.intercept_um))
    page.table(("reference line", "straightness (µm)", f"U, k = {K:g} (µm)", "95 % interval (µm)",
                "slope (µm/m)", "intercept (µm)"), rows, text_columns=(0, 3))
    page.paragraph("Straightness = max − min of the deviations from the named reference line "
                   "(ISO 230-1 straightness error); the minimum-zone value is the smallest of the three. "
                   + uncertainty_method_text(r), "note")


def run_events_section(page: HtmlPage, meta: dict[str, Any]) -> None:
    """Warm-up check and stations the operator skipped (run format v2, docs/run-format.md)."""
    warmup = meta.get("warmup")
    if isinstance(warmup, dict):
        stable = warmup.get("stable")
        state = "stable" if stable else ("not stable, overridden by the operator" if warmup.get("overridden")
                                         else "not stable")
        duration = warmup.get("duration_s")
        page.paragraph(f"Warm-up: {state}" + (f" after {duration:.0f} s" if isinstance(duration, (int, float))
                                              else "") + ".", "" if stable else "alert")
    skipped = meta.get("skipped")
    if isinstance(skipped, list) and skipped:
        page.heading("Skipped stations", 3)
        page.table(("station", "pass", "reason"),
                   [(s.get("station"), "return" if s.get("pass") == 1 else "forward", s.get("reason", ""))
                    for s in skipped if isinstance(s, dict)], text_columns=(1, 2))


def uncertainty_method_text(r: StraightnessResult) -> str:
    if r.uncertainty is None:
        return "No uncertainty evaluated."
    if r.uncertainty.monte_carlo is None:
        return "U of the straightness values not evaluated (Monte Carlo off); per-station u by GUM."
    return "U: " + r.uncertainty.to_dict()["straightness_method"] + "."


def wavelength_section(page: HtmlPage, r: StraightnessResult) -> None:
    page.heading("Dominant wavelengths", 3)
    if not r.wavelengths:
        page.paragraph("None found (too few stations or no periodic component above the noise).", "note")
        return
    page.table(("rank", "wavelength (mm)", "amplitude (µm)"),
               [(i, p.wavelength_mm, p.amplitude_um) for i, p in enumerate(r.wavelengths, start=1)], digits=3)
    page.paragraph("Spectrum of the least-squares-detrended profile; only wavelengths shorter than the measured "
                   "length are reported (a longer one is not resolved by the measurement).", "note")


def return_pass_section(page: HtmlPage, r: StraightnessResult) -> None:
    rp = r.return_pass
    if rp is None:
        return
    page.heading("Return pass", 3)
    page.key_values([("profile", "mean of the forward and the return pass at each station"),
                     ("closure error (µm)", rp.closure_um), ("drift (µm/h)", rp.drift_um_per_h)])


def uncertainty_section(page: HtmlPage, r: StraightnessResult) -> None:
    if r.uncertainty is None:
        return
    page.heading("Uncertainty inputs (standard uncertainties, k = 1)", 3)
    d = r.uncertainty.inputs.to_dict()
    rows = [(name.replace("_", " "), unit.replace("um", "µm").replace("urad", "µrad"), v)
            for name, unit, v in ((*key.rsplit("_", 1), v) for key, v in d.items())]
    page.table(("input", "unit", "u"), rows, digits=4, text_columns=(0, 1))
    page.paragraph("Per-station u: " + r.uncertainty.to_dict()["per_station_method"] + ".", "note")


def stations_section(page: HtmlPage, r: StraightnessResult) -> None:
    page.heading("Per station", 3)
    names = list(r.lines)
    u = r.uncertainty.per_station_u_um if r.uncertainty is not None else None
    rows = []
    for i, row in enumerate(r.profile.itertuples(index=False)):
        devs = [r.lines[n].deviations_um[i] for n in names]
        unc = [] if u is None else [float(u[i]), float(K * u[i])]
        rows.append((int(row.station), float(row.x_mm), float(row.height_um), *map(float, devs), *unc))
    header = ["station", "x (mm)", "height (µm)", *(f"dev. {line_label(n)} (µm)" for n in names)]
    if u is not None:
        header += ["u, k = 1 (µm)", f"U, k = {K:g} (µm)"]
    page.table(header, rows, digits=3)
