"""Report sections of a positioning run: plot, ISO 230-2 table (English and GB/T names),
VDI/DGQ 3441, per-target table, environmental compensation, notes and the residual
after compensation per model.  Deviations in µm (linear) or arcsec (rotary)."""

from __future__ import annotations

import math

from processing.compensation.residuals import basis_text
from processing.iso230_2 import AXIS_QUANTITIES, QUANTITY_NAMES, VDI3441_NAMES, VDI3441_QUANTITIES

from ..errors import UserError
from ..evaluation.positioning import PositioningEvaluation
from ..export.build import build_export
from ..export.options import ExportOptions
from ..export.residuals import CV_LABELS
from ..results.positioning import positioning_figure
from ..store.compensation import compensation_text, run_compensation
from .common import verdict_section
from .html import HtmlPage, figure_png

UNIT_TEXT = {"um": "µm", "arcsec": "arcsec", "mm": "mm", "deg": "°"}


HEADLINE_FAMILIES = (("A", "A_up", "A_down"), ("E", "E_up", "E_down"), ("R", "R_up", "R_down"), ("M",), ("B",))


def positioning_headline(page: HtmlPage, evaluation: PositioningEvaluation) -> None:
    """The ISO 230-2 values of the axis in one line (bidirectional, else the direction measured)
    and the verdict against the set-up's tolerance."""
    r = evaluation.result
    a = r.axis
    shown = [next((q for q in fam if math.isfinite(a.get(q, math.nan))), None) for fam in HEADLINE_FAMILIES]
    values = ", ".join(f"{q} = {a[q]:.3f}" for q in shown if q is not None)
    page.heading("Result")
    page.paragraph(f"{r.edition} (k = {r.k:g}): {values or 'no value evaluable'} {UNIT_TEXT[r.unit]}", "headline")
    verdict_section(page, evaluation.verdict, f"A_{r.unit}, E_{r.unit}, R_{r.unit}, M_{r.unit}, B_{r.unit}, ...")


def positioning_sections(page: HtmlPage, evaluation: PositioningEvaluation) -> None:
    r = evaluation.result
    unit = UNIT_TEXT[r.unit]
    setup = evaluation.run.meta.get("setup") or {}
    page.heading(f"Positioning ({r.edition})")
    page.key_values([
        ("standard", f"{r.edition} (formulas shared by the 1997, 2006 and 2014 editions); "
                     "Chinese adoption GB/T 17421.2"),
        ("axis", f"{setup.get('axis_name') or evaluation.run.meta.get('axis') or '—'} ({r.axis_type})"),
        ("targets", len(r.per_target)),
        ("approaches per target, ↑ / ↓", f"{r.runs_up} / {r.runs_down}"),
        ("directions", r.directions),
        ("coverage factor k", r.k),
        ("deviation", f"x_ij = actual − target, {unit}, after environmental compensation"),
        ("controller compensation", compensation_text(run_compensation(evaluation.run.meta))
         .removeprefix("controller compensation: ")),
    ], digits=3)
    page.image(figure_png(positioning_figure(evaluation.result, evaluation.deviations)),
               f"Top: every approach (thin lines; blue ↑, red ↓), the mean per direction with its "
               f"± {r.k:g} s band. Bottom: reversal value B_i per target ({unit}).")
    iso_table(page, evaluation)
    vdi_table(page, evaluation)
    notes_section(page, evaluation)
    environment_compensation_section(page, evaluation)
    per_target_table(page, evaluation)
    residual_section(page, evaluation)


def iso_table(page: HtmlPage, evaluation: PositioningEvaluation) -> None:
    r = evaluation.result
    page.heading(f"{r.edition} results (k = {r.k:g})", 3)
    budget = evaluation.budget or {}

    def big_u(q: str) -> float | None:
        b = budget.get(q)
        return None if b is None else b.U

    rows = [(q, r.axis[q], big_u(q), UNIT_TEXT[r.unit], *QUANTITY_NAMES[q]) for q in AXIS_QUANTITIES]
    page.table(("symbol", "value", f"U (k = {r.k:g})", "unit", "ISO 230-2 name", "GB/T 17421.2 name"), rows,
               digits=3, text_columns=(0, 3, 4, 5))
    page.paragraph("— = not evaluable from this data (see the notes). GB/T names as commonly quoted; check "
                   "the clause wording against the standard before quoting it in a contract.", "note")
    budget_section(page, evaluation)


def budget_section(page: HtmlPage, evaluation: PositioningEvaluation) -> None:
    """The standard uncertainty contributions of E, M, A, B and R (ISO 230-2 Annex A / ISO/TR 230-9)."""
    budget = evaluation.budget or {}
    shown = [q for q in ("E", "M", "A", "B", "R") if q in budget]
    if not shown:
        return
    unit = UNIT_TEXT[evaluation.result.unit]
    page.heading(f"Uncertainty budget (standard uncertainties, {unit})", 3)
    names: list[str] = []
    for q in shown:
        names += [n for n in budget[q].contributions if n not in names]
    rows: list[tuple[object, ...]] = [(n, *(budget[q].contributions.get(n) for q in shown)) for n in names]
    rows += [("combined u_c", *(budget[q].u_c for q in shown)),
             ("expanded U = k·u_c", *(budget[q].U for q in shown))]
    page.table(("contribution", *shown), rows, digits=3)
    notes = sorted({n for q in shown for n in budget[q].notes})
    page.paragraph("— = cancels in this value or does not apply. " + "; ".join(notes), "note")


def vdi_table(page: HtmlPage, evaluation: PositioningEvaluation) -> None:
    r = evaluation.result
    page.heading("VDI/DGQ 3441 (for comparison)", 3)
    page.table(("symbol", "value", "unit", "name"),
               [(q, r.vdi3441[q], UNIT_TEXT[r.unit], VDI3441_NAMES[q]) for q in VDI3441_QUANTITIES],
               digits=3, text_columns=(0, 2, 3))


def notes_section(page: HtmlPage, evaluation: PositioningEvaluation) -> None:
    if not evaluation.result.notes:
        return
    page.heading("Notes", 3)
    for note in evaluation.result.notes:
        page.paragraph(f"Note: {note}")


def environment_compensation_section(page: HtmlPage, evaluation: PositioningEvaluation) -> None:
    env = evaluation.environment
    page.heading("Environmental compensation", 3)
    items: list[tuple[str, object]] = [("applied", env.applied), ("what / why", env.reason)]
    if env.applied:
        items += [
            ("air-index equation", env.equation_name or env.equation),
            ("formulas", "; ".join(env.formulas)),
            ("index assumed by the controller", f"{env.refractive_index_assumed:.9f}"),
            ("air index n, min … max", f"{env.index_min:.9f} … {env.index_max:.9f}"),
            ("air index at the datum n0", f"{env.index_datum:.9f}"),
            ("vacuum wavelength (nm)", env.wavelength_nm),
            ("CO₂ (ppm)", env.co2_ppm),
            ("dead path (mm)", env.dead_path_mm),
            ("expansion coefficient (ppm/K)", env.expansion_ppm_per_k),
        ]
        if env.material_temp_min_c is not None:
            items.append(("material temperature, min … max (°C)",
                          f"{env.material_temp_min_c:.3f} … {env.material_temp_max_c:.3f}"))
    page.key_values(items, digits=3)


def per_target_table(page: HtmlPage, evaluation: PositioningEvaluation) -> None:
    r = evaluation.result
    u = UNIT_TEXT[r.unit]
    page.heading(f"Per target ({u})", 3)
    cols = ("target_index", "target", "n_up", "n_down", "mean_up", "mean_down", "mean_bi", "reversal",
            "s_up", "s_down", "R_i_up", "R_i_down", "R_i")
    header = ("i", f"target ({UNIT_TEXT[r.target_unit]})", "n ↑", "n ↓", "x̄ ↑", "x̄ ↓", "x̄ bi", "B_i",
              "s ↑", "s ↓", "R ↑", "R ↓", "R")
    rows = [tuple(row) for row in r.per_target[list(cols)].itertuples(index=False)]
    rows = [(int(t[0]), float(t[1]), int(t[2]), int(t[3]), *map(float, t[4:])) for t in rows]
    page.table(header, rows, digits=3)
    page.paragraph(f"x̄ = mean deviation, B_i = x̄↑ − x̄↓, s = standard uncertainty estimator (n − 1), "
                   f"R↑/R↓ = 2·k·s, R = max(k·s↑ + k·s↓ + |B_i|, R↑, R↓), k = {r.k:g}.", "note")


def residual_section(page: HtmlPage, evaluation: PositioningEvaluation) -> None:
    """The model comparison ``guideway export`` prints (CSV format: each model's own nodes)."""
    page.heading("Residual after compensation, per model", 3)
    try:
        export = build_export(evaluation.result, ExportOptions(fmt="csv"), deviations=evaluation.deviations)
    except UserError as exc:
        page.paragraph(f"Not computed: {exc}", "note")
        return
    u = UNIT_TEXT[export.error_unit]
    rows = []
    for row in export.comparison.itertuples(index=False):
        if row.note:
            rows.append((row.model, "—", None, None, None, None, None, None, f"not fitted: {row.note}"))
            continue
        pts = "—" if row.model == "none" else int(row.table_points)
        rows.append((row.model, pts, row.max_abs, row.range, row.rms, row.reduction_pct, row.E, row.M, row.detail))
    page.table(("model", "table points", f"max |r| ({u})", f"range ({u})", f"RMS ({u})",
                "range reduction (%)", f"E ({u})", f"M ({u})", "note"), rows, digits=3, text_columns=(0, 8))
    page.paragraph(f"{_sentence(basis_text(export.comparison))}. Bidirectional table of each model on its own "
                   "nodes (as `guideway export --format csv`); the controller interpolates linearly between table "
                   "points. 'none' = uncompensated; E, M = ISO 230-2 E and M of the compensated per-target means.",
                   "note")
    cross_validation_table(page, export.residuals, u)


def cross_validation_table(page: HtmlPage, residuals: dict, u: str) -> None:
    """In-sample against leave-one-run-out and leave-one-target-out residual of every model."""
    page.heading("Residual out of sample, per model", 3)
    kinds = ("in_sample", "leave_one_run_out", "leave_one_target_out")
    rows, notes = [], {}
    for name, res in residuals.items():
        cells: list[object] = [name]
        for k in kinds:
            o = res[k]
            cells += [getattr(o, "rms", None), getattr(o, "max_abs", None)]
            if hasattr(o, "reason"):
                notes.setdefault(f"{CV_LABELS[k]}: {o.reason}", None)
            elif k != "in_sample" and o.folds < o.of_folds:
                notes.setdefault(f"{CV_LABELS[k]}: {o.folds} of {o.of_folds} targets held out in turn (evenly "
                                 "spread, both ends)", None)
        rows.append(tuple(cells))
    page.table(("model", f"in-sample RMS ({u})", f"in-sample max |r| ({u})", f"leave-one-run-out RMS ({u})",
                f"leave-one-run-out max |r| ({u})", f"leave-one-target-out RMS ({u})",
                f"leave-one-target-out max |r| ({u})"), rows, digits=3)
    page.paragraph("In-sample: the table scored on the data it was fitted to (a table through the means leaves "
                   "only the run-to-run scatter). Leave-one-run-out: each model refitted without one run and scored "
                   "on that run (a repeat of the measurement). Leave-one-target-out: refitted without one target and "
                   "scored there (positions between the targets; an end target is held at its neighbour's value). "
                   + " ".join(f"{n}." for n in notes), "note")


def _sentence(text: str) -> str:
    return text[:1].upper() + text[1:]
