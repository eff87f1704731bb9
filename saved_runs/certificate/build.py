"""``guideway certificate RUN --out FILE.pdf``: a calibration certificate of a saved run (ISO/IEC 17025:2017
7.8.2.1, 7.8.4, 7.8.6), typeset with typst (.typeset).  Every field and where it comes from:
docs/certificate.md.

Refused with one line (exit 2): a run that cannot be evaluated (not complete, a gap in its plan, damaged
files), an instrument whose calibration was due before the run, an issue date before the measurement.
The same run and options give the same bytes: no clock, no random id (the issue date is an option or
the run's date).
"""

from __future__ import annotations

import datetime
import hashlib
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..errors import RunFormatError, UserError
from ..evaluation.evaluate import evaluate_run
from ..evaluation.tolerance import DECISION_RULE_NAMES, DEFAULT_DECISION_RULE, OUTCOME_WORDS
from ..report.common import environment_summary, reported_identity, simulated
from ..store.compensation import run_compensation
from ..store.instruments import expired, run_instruments
from ..store.reader import LoadedRun, load_run
from ..toml_file import TomlTable, read_toml
from .typeset import TypstDoc, compile_pdf, lit

UNIT = {"um": "µm", "arcsec": "arcsec", "mm": "mm", "deg": "°"}
NOT_STATED = "not stated"
RELATE_ONLY = "The results relate only to the item calibrated."
NOT_ACCREDITED = ("This certificate is not issued under accreditation: the laboratory holds no accreditation "
                  "for this calibration, and no accreditation body's mark or statement applies to it.")
END_LINE = "End of certificate"
# ISO 230-2 values per direction: (row name, ↑, ↓, bidirectional)
POSITIONING_ROWS = (("A (accuracy)", "A_up", "A_down", "A"), ("E (systematic deviation)", "E_up", "E_down", "E"),
                    ("R (repeatability)", "R_up", "R_down", "R"), ("M (mean deviation)", None, None, "M"),
                    ("B (reversal value)", None, None, "B"), ("B mean (mean reversal)", None, None, "B_mean"))
LINE_NAMES = {"endpoint": "end-point line", "least_squares": "least-squares line", "minimum_zone": "minimum-zone line"}


def run_sha256(run_dir: Path) -> str:
    """SHA-256 of the bytes of run.json followed by the bytes of points.csv (as on disk): which data the
    certificate was made from (``sha256sum``: ``cat run.json points.csv | sha256sum``)."""
    h = hashlib.sha256()
    for name in ("run.json", "points.csv"):
        h.update((run_dir / name).read_bytes())
    return h.hexdigest()


def _date(text: Any) -> datetime.date | None:
    if not isinstance(text, str) or len(text) < 10:
        return None
    try:
        return datetime.date.fromisoformat(text[:10])
    except ValueError:
        return None


def measurement_dates(meta: dict[str, Any]) -> tuple[datetime.date, datetime.date]:
    """(first, last) date of the measurement (UTC) from run.json ``created`` and ``ended``."""
    start = _date(meta.get("created"))
    if start is None:
        raise RunFormatError(f"run.json created {meta.get('created')!r} is not an ISO 8601 date-time; "
                             "the measurement date is unknown")
    return start, _date(meta.get("ended")) or start


@dataclass(frozen=True)
class Party:
    """A laboratory (``--lab``) or customer (``--customer``) TOML file; ``values`` by key."""

    values: dict[str, str] = field(default_factory=dict)
    item: dict[str, str] = field(default_factory=dict)

    def get(self, key: str) -> str:
        return self.values.get(key) or NOT_STATED


LAB_KEYS = ("name", "address", "accreditation", "place", "authoriser", "authoriser_role")
CUSTOMER_KEYS = ("name", "address", "reference")
ITEM_KEYS = ("serial", "controller", "condition", "model")


def read_party(path: Path | str | None, keys: tuple[str, ...], what: str) -> Party:
    """A ``--lab`` / ``--customer`` file (string values; the customer's ``[item]`` table); empty without one."""
    if path is None:
        return Party()
    top = TomlTable(str(path), "", read_toml(path), examples="docs/certificate.md")
    values = {k: top.get(k, str, "") for k in keys}
    item: dict[str, str] = {}
    if what == "customer":
        it = top.table("item")
        item = {k: it.get(k, str, "") for k in ITEM_KEYS}
        it.check_unknown()
    top.check_unknown()
    return Party({k: v.strip() for k, v in values.items()}, {k: v.strip() for k, v in item.items()})


@dataclass(frozen=True)
class CertificateOptions:
    number: str | None = None
    issue_date: datetime.date | None = None
    decision_rule: str = DEFAULT_DECISION_RULE
    lab: Path | None = None
    customer: Path | None = None
    as_left: Path | None = None
    # the evaluator options of ``process`` (method, mc_trials, k, edition, accept_out_of_range; None: default),
    # applied to both runs
    evaluation: dict[str, Any] = field(default_factory=dict)


def evaluable(run_dir: Path | str, rule: str, role: str = "",
              options: dict[str, Any] | None = None) -> tuple[LoadedRun, Any]:
    """Load and evaluate a run for a certificate; one-line refusal of one that is not complete, has a gap,
    or cannot be read or evaluated."""
    who = f"{role} run " if role else ""
    try:
        run = load_run(run_dir)
    except (RunFormatError, UserError, OSError) as exc:
        raise RunFormatError(f"{who}{run_dir}: cannot issue a certificate: the run cannot be read "
                             f"({exc})") from None
    status = run.meta.get("status")
    if status != "complete":
        raise RunFormatError(f"{who}{run_dir}: cannot issue a certificate of a run whose status is {status!r} "
                             f"(only complete runs are certified; {run.meta.get('end_reason') or 'not finished'})")
    try:
        evaluation = evaluate_run(run, **{**(options or {}), "decision_rule": rule})
    except (RunFormatError, UserError) as exc:
        raise RunFormatError(f"{who}{run_dir}: cannot issue a certificate: the run cannot be evaluated "
                             f"({exc})") from None
    if getattr(evaluation, "gaps", ()):
        raise RunFormatError(f"{who}{run_dir}: cannot issue a certificate of an incomplete run "
                             f"({evaluation.to_dict()['missing_steps']['text']})")
    return run, evaluation


def check_instruments(run: LoadedRun, role: str = "") -> list[dict[str, str]]:
    """The run's calibrated instruments; refuses (one line) one whose calibration was due before the run."""
    instruments = run_instruments(run.meta, f"{run.path}/run.json")
    _, last = measurement_dates(run.meta)
    late = expired(instruments, last)
    if late is not None:
        raise UserError(f"{role + ' run ' if role else ''}{run.path}: instrument {late['role']!r} ({late['model']}"
                        f"{', serial ' + late['serial'] if 'serial' in late else ''}) was due for calibration on "
                        f"{late['due']}, before the measurement on {last.isoformat()}; no certificate can be issued "
                        "(recalibrate it and measure again)")
    return instruments


def _f(v: Any, digits: int = 3) -> str:
    if isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v):
        text = f"{v:.{digits}f}"
        return text[1:] if text.startswith("-") and float(text) == 0 else text
    return "—"


def build_certificate(run_dir: Path | str, out: Path | str, options: CertificateOptions) -> Path:
    """Write the certificate of ``run_dir`` to ``out`` (PDF); return the path."""
    from ..store.files import write_atomic

    pdf = certificate_pdf(run_dir, options)
    out = Path(out)
    if out.suffix.lower() != ".pdf":
        raise UserError(f"--out {out}: the certificate is a PDF; name the file *.pdf")
    write_atomic(out, lambda f: f.write(pdf))
    return out


def certificate_pdf(run_dir: Path | str, options: CertificateOptions) -> bytes:
    """The certificate's PDF bytes (deterministic in ``run_dir``'s files and ``options``)."""
    rule = options.decision_rule
    run, evaluation = evaluable(run_dir, rule, options=options.evaluation)
    instruments = check_instruments(run)
    left = None
    if options.as_left is not None:
        left_run, left_eval = evaluable(options.as_left, rule, "as-left", options.evaluation)
        check_instruments(left_run, "as-left")
        if left_run.kind != run.kind:
            raise UserError(f"--as-left {options.as_left}: a {left_run.kind} run; the as-found run is a "
                            f"{run.kind} run")
        left = (left_run, left_eval)
    lab = read_party(options.lab, LAB_KEYS, "lab")
    customer = read_party(options.customer, CUSTOMER_KEYS, "customer")
    sha = run_sha256(run.path)
    first, last = measurement_dates(run.meta)
    if left is not None:
        last = max(last, measurement_dates(left[0].meta)[1])
    issue = options.issue_date or last
    if issue < last:
        raise UserError(f"--issue-date {issue.isoformat()} is before the measurement ({last.isoformat()}); "
                        "a certificate is issued after the work")
    number = options.number or f"GW-{sha[:10].upper()}"
    why_sim = simulated(run.meta) or (simulated(left[0].meta) if left else None)
    banner = f"SIMULATED RUN — not a measurement of a machine ({why_sim})" if why_sim else None

    doc = TypstDoc()
    doc.code("#align(center, text(size: 17pt, weight: \"bold\", \"Calibration certificate\"))")
    doc.code(f"#align(center, text(size: 11pt, {lit('No. ' + number)}))")
    dates = first.isoformat() + ("" if last == first else f" to {last.isoformat()}")
    doc.key_values([
        ("Certificate number", number),
        ("Date(s) of measurement", dates),
        ("Date of issue", issue.isoformat()),
        ("Place of calibration", lab.get("place")),
    ])
    doc.heading("Laboratory")
    doc.key_values([("Name", lab.get("name")), ("Address", lab.get("address")),
                    ("Accreditation", lab.values.get("accreditation") or NOT_ACCREDITED)])
    doc.heading("Customer")
    doc.key_values([("Name", customer.get("name")), ("Address", customer.get("address")),
                    ("Customer reference", customer.get("reference"))])
    item_section(doc, run, evaluation, customer)
    method_section(doc, run, evaluation)
    instruments_section(doc, run, instruments, left[0] if left else None)
    environment_section(doc, run, evaluation)
    results_section(doc, run, evaluation)
    if left is not None:
        as_left_section(doc, (run, evaluation), left)
    conformity_section(doc, evaluation, rule, left[1] if left else None)
    closing_section(doc, lab, sha, left[0] if left else None)
    footer = (f"Certificate {number} · issued {issue.isoformat()} · data: run SHA-256 {sha} "
              "(of run.json followed by points.csv)")
    return compile_pdf(doc, number=number, banner=banner, footer=footer, title=f"Calibration certificate {number}",
                       timestamp=issue)


def _axis_text(run: LoadedRun, evaluation: Any) -> tuple[str, str, str]:
    """(axis name, travel, linear / rotary) of the item."""
    m, s = run.meta, run.meta.get("setup") or {}
    if run.kind == "positioning":
        unit = "deg" if m.get("axis_type") == "rotary" else "mm"
        targets = s.get(f"targets_{unit}") or []
        travel = (f"{min(targets):g} to {max(targets):g} {UNIT[unit]} ({len(targets)} targets)" if targets
                  else NOT_STATED)
        return str(s.get("axis_name") or m.get("axis") or NOT_STATED), travel, str(m.get("axis_type", "linear"))
    prof = evaluation.result.profile
    span = float(prof["x_mm"].max() - prof["x_mm"].min()) if len(prof) else 0.0
    return (str(m.get("axis") or NOT_STATED),
            f"{span:g} mm measured ({len(prof)} stations × {s.get('block_length_mm', '?')} mm block)", "linear")


def item_section(doc: TypstDoc, run: LoadedRun, evaluation: Any, customer: Party) -> None:
    name, travel, kind = _axis_text(run, evaluation)
    it = customer.item
    doc.heading("Item calibrated")
    doc.key_values([
        ("Machine", str(run.meta.get("machine") or NOT_STATED)),
        ("Model", it.get("model") or NOT_STATED),
        ("Serial number", it.get("serial") or NOT_STATED),
        ("Controller", it.get("controller") or NOT_STATED),
        ("Axis", f"{name} ({kind})"),
        ("Travel", travel),
        ("Condition on receipt", it.get("condition") or NOT_STATED),
    ])


def method_section(doc: TypstDoc, run: LoadedRun, evaluation: Any) -> None:
    s = run.meta.get("setup") or {}
    doc.heading("Method")
    deviations: list[str] = []
    if run.kind == "positioning":
        r = evaluation.result
        u = "deg" if r.axis_type == "rotary" else "mm"
        doc.para(f"{r.edition}, Test code for machine tools — Determination of accuracy and repeatability of "
                 f"positioning of numerically controlled axes; {r.directions} approach.")
        cycle_name = "ISO 230-2 Annex B step cycle" if s.get("cycle") == "step" else "standard test cycle"
        targets = ", ".join(f"{t:g}" for t in (s.get(f"targets_{u}") or []))
        doc.key_values([
            ("Cycle", f"{s.get('cycle', 'linear')} ({cycle_name})"),
            ("Targets", f"{len(r.per_target)}: {targets} {UNIT[u]}"),
            ("Runs per direction", f"{r.runs_up} ↑ / {r.runs_down} ↓ (planned {s.get('runs', 5)})"),
            ("Feed", f"{s.get(f'feed_{u}_min', '—')} {UNIT[u]}/min"),
            ("Overrun", f"{s.get(f'overrun_{u}', '—')} {UNIT[u]}"),
            ("Dwell", f"{s.get('dwell_s', '—')} s"),
            ("Trigger", str(s.get("trigger", NOT_STATED))),
            ("Coverage factor k (ISO 230-2 bands ± k·s)", f"{r.k:g}"),
            ("Deviation", f"x = actual − target, {UNIT[r.unit]}, after environmental compensation"),
        ])
        deviations += list(r.notes)
    else:
        r = evaluation.result
        g = s.get("geometry") or {}
        doc.para("Gauge-block step method (guideway): a gauge block stepped along the guideway by its own length; "
                 "at each station a 6-DOF interferometer measures the block's pose and a displacement sensor the "
                 "height of the surface; the block's own pitch, roll and straightness are decoupled from the "
                 "sensor reading. Straightness per ISO 230-1 against the stated reference line.")
        doc.key_values([
            ("Block length (step)", f"{s.get('block_length_mm', '—')} mm"),
            ("Stations planned / measured", f"{s.get('stations', '—')} / {len(r.profile)}"),
            ("Return pass", "yes" if s.get("return_pass") else "no"),
            ("Samples per reading", str(s.get("samples_per_reading", "—"))),
            ("Decoupling", r.method),
            ("Mirror P, sensor Q (block frame, mm)", f"{g.get('mirror_mm', '—')}, {g.get('sensor_mm', '—')}"),
            ("Reference lines", "minimum zone (ISO 1101), least squares, end points; the specification's line "
                                "decides conformity"),
        ])
    for o in getattr(evaluation, "out_of_range", ()):
        deviations.append(f"value outside the validation limits evaluated anyway: {o.where} {o.column} {o.value}")
    if run.meta.get("skipped"):
        deviations.append(f"{len(run.meta['skipped'])} planned step(s) skipped by the operator")
    doc.para("Deviations from the method: " + ("; ".join(deviations) if deviations else "none."))


def instruments_section(doc: TypstDoc, run: LoadedRun, instruments: list[dict[str, str]],
                        left: LoadedRun | None) -> None:
    doc.heading("Instruments and traceability")
    if left is not None:
        extra = [i for i in run_instruments(left.meta, f"{left.path}/run.json") if i not in instruments]
        instruments = instruments + extra
    if instruments:
        doc.table(("role", "model", "serial", "certificate", "calibrated", "due"),
                  [(i["role"], i["model"], i.get("serial", NOT_STATED), i.get("certificate", NOT_STATED),
                    i.get("calibrated", NOT_STATED), i.get("due", "no due date stated"))
                   for i in instruments])
        doc.para("Traceability: the measurement results are traceable to the SI through the calibrations of the "
                 "instruments above, as stated on their calibration certificates; each was within its calibration "
                 "interval on the dates of measurement (an instrument without a due date is marked so; its "
                 "interval was not stated).")
    else:
        doc.para("No calibrated instruments are recorded for this run (set-up [[instrument]] tables, run.json "
                 "setup.instruments): traceability of these results to the SI is not stated by this certificate.")
    devices = run.meta.get("instruments") or {}
    if devices:
        rows = []
        for role, info in devices.items():
            if not isinstance(info, dict):
                continue
            reported, _ = reported_identity(role, info)
            rows.append((role, str(info.get("protocol", "—")),
                         ", ".join(f"{k}: {v}" for k, v in reported) or "not reported by the device"))
        doc.para("Identities the devices reported during the run:")
        doc.table(("device", "protocol", "identity reported by the device"), rows, "(auto, auto, 1fr)")


def environment_section(doc: TypstDoc, run: LoadedRun, evaluation: Any) -> None:
    doc.heading("Environmental conditions")
    rows = environment_summary(run.points)
    if rows:
        doc.table(("quantity", "min", "mean", "max", "start", "end"),
                  [(r["quantity"], _f(r["min"]), _f(r["mean"]), _f(r["max"]), _f(r["start"]), _f(r["end"]))
                   for r in rows])
    else:
        doc.para("No environmental values were recorded.")
    kv: list[tuple[str, str]] = []
    if run.kind == "positioning":
        env = evaluation.environment
        kv.append(("Environmental compensation",
                   env.reason + (f" ({env.equation_name})" if env.equation_name else "")))
        if env.expansion_ppm_per_k is not None:
            kv.append(("Expansion coefficient α", f"{env.expansion_ppm_per_k:g} ppm/K (normalised to 20 °C)"))
    else:
        kv.append(("Air index", "not applied: the straightness channels and the displacement sensor are read as "
                                "given (the index cancels to first order in a straightness reading)"))
        rp = evaluation.result.return_pass
        if rp is not None and rp.drift_um_per_h is not None:
            kv.append(("Drift (return pass)", f"{_f(rp.drift_um_per_h)} µm/h, closure {_f(rp.closure_um)} µm"))
    t = run.points.get("time_s")
    hours = float(t.max() - t.min()) / 3600.0 if t is not None and len(t) > 1 else 0.0
    for r in rows:
        if r["column"] in ("air_temp_c", "material_temp_c"):
            # a rate only over a run long enough to state one (a 10 s demo run would give a huge °C/h)
            rate = f", {_f((r['end'] - r['start']) / hours)} °C/h" if hours >= 0.1 else ""
            kv.append((f"Drift of {r['quantity']}", f"end − start {_f(r['end'] - r['start'])} °C over "
                                                     f"{hours * 60:.1f} min{rate}"))
    doc.key_values(kv)


def results_section(doc: TypstDoc, run: LoadedRun, evaluation: Any) -> None:
    from ..report.html import figure_png

    doc.heading("Results")
    if run.kind == "positioning":
        from ..results.positioning import positioning_figure

        r = evaluation.result
        unit = UNIT[r.unit]
        budget = evaluation.budget or {}

        def value_u(q: str | None) -> tuple[str, str]:
            if q is None:
                return "", ""
            b = budget.get(q)
            return _f(r.axis.get(q)), _f(b.U) if b is not None and b.U is not None else "not known"

        doc.para(f"ISO 230-2 values ({r.edition}) in {unit}, each with its expanded uncertainty U = k·u_c, "
                 f"k = {r.k:g} (ISO 230-2 Annex A / ISO/TR 230-9 budget below); k = {r.k:g} also for the bands "
                 "± k·s that A and R contain.")
        doc.table(("value", f"↑ ({unit})", f"U ↑ ({unit})", f"↓ ({unit})", f"U ↓ ({unit})",
                   f"bidirectional ({unit})", f"U ({unit})"),
                  [(name, *value_u(up), *value_u(dn), *value_u(bi)) for name, up, dn, bi in POSITIONING_ROWS])
        budget_table(doc, budget, unit)
        doc.image("positioning.png", figure_png(positioning_figure(r, evaluation.deviations), dpi=110),
                  f"Every approach (blue ↑, red ↓), the mean per direction with its ± {r.k:g} s band; "
                  f"reversal value per target ({unit}).")
        return
    from ..results.straightness import profile_figure

    r = evaluation.result
    unc = r.uncertainty.to_dict() if r.uncertainty is not None else {}
    mc_u = unc.get("straightness", {})
    doc.table(("straightness against", "value (µm)", "U (µm)", "k"),
              [(LINE_NAMES.get(n, n), _f(v), _f(mc_u.get(n)), "2" if n in mc_u else "—")
               for n, v in r.straightness_um().items()])
    doc.para(f"U: {unc.get('straightness_method', 'no Monte Carlo evaluation (U of the straightness not known)')}.")
    doc.para(gum_mc_agreement(r))
    doc.image("profile.png", figure_png(profile_figure(r), dpi=110),
              "Surface profile with its reference lines and the U (k = 2) band per station; below, the deviations "
              "from the minimum-zone line.")


def gum_mc_agreement(result: Any) -> str:
    """Whether the GUM (law of propagation) and the Monte Carlo (GUM-S1) per-station expanded uncertainties
    agree, by GUM-S1 §8: |U_GUM − U_MC| at every station within the numerical tolerance δ of u (two
    significant digits: δ = ½·10^l for u = c·10^l)."""
    import numpy as np

    unc = result.uncertainty
    if unc is None or unc.monte_carlo is None:
        return "GUM and Monte Carlo: only the GUM evaluation was made (no Monte Carlo): agreement not checked."
    u_gum = np.asarray(unc.per_station_u_um, dtype=float)
    u_mc = np.asarray(unc.monte_carlo.per_station_std_um, dtype=float)
    diff = np.abs(2.0 * (u_gum - u_mc))
    u_max = float(np.max(u_gum)) if len(u_gum) else 0.0
    if not (u_max > 0 and math.isfinite(u_max)):
        return "GUM and Monte Carlo: no uncertainty to compare."
    delta = 0.5 * 10.0 ** (math.floor(math.log10(u_max)) - 1)
    worst = float(np.max(diff))
    verdict = "agree" if worst <= delta else "do not agree"
    return (f"GUM and Monte Carlo {verdict} (GUM-S1 §8): largest difference of the per-station U (k = 2) "
            f"{worst:.4f} µm, numerical tolerance δ = {delta:g} µm (largest GUM u {u_max:.3f} µm, two significant "
            "digits).")


BUDGET_COLUMNS = ("E", "M", "A", "B", "R")  # the bidirectional values; the one-direction ones are in run JSON


def budget_table(doc: TypstDoc, budget: dict[str, Any], unit: str) -> None:
    """The standard uncertainty contributions of the bidirectional ISO 230-2 values, u_c, U and k."""
    shown = [q for q in BUDGET_COLUMNS if q in budget]
    if not shown:
        return
    names: list[str] = []
    for q in shown:
        names += [n for n in budget[q].contributions if n not in names]
    rows = [(n, *(_f(budget[q].contributions[n]) if n in budget[q].contributions else "cancels / n.a."
                  for q in shown)) for n in names]
    rows.append(("length L the scale terms act over (mm)",
                 *(_f(budget[q].length_mm, 1) if budget[q].length_mm is not None else "—" for q in shown)))
    rows.append(("combined standard uncertainty u_c", *(_f(budget[q].u_c) for q in shown)))
    rows.append(("coverage factor k", *(f"{budget[q].k:g}" for q in shown)))
    rows.append(("expanded uncertainty U = k·u_c", *(_f(budget[q].U) for q in shown)))
    doc.para(f"Uncertainty budget (ISO 230-2 Annex A / ISO/TR 230-9; standard uncertainties in {unit}):", bold=True)
    doc.table(("contribution", *shown), rows)
    notes = sorted({n for q in shown for n in budget[q].notes})
    if notes:
        doc.para("Not included / assumed: " + "; ".join(notes) + ".", size="8pt")


def _values(evaluation: Any) -> dict[str, tuple[float, float | None, str]]:
    """{name: (value, U or None, unit)} compared as found / as left."""
    if hasattr(evaluation.result, "axis"):
        r = evaluation.result
        budget = evaluation.budget or {}
        return {q: (v, budget[q].U if q in budget else None, UNIT[r.unit]) for q, v in r.axis.items() if q in
                ("A", "A_up", "A_down", "E", "E_up", "E_down", "R", "R_up", "R_down", "M", "B")}
    r = evaluation.result
    mc_u = (r.uncertainty.to_dict() if r.uncertainty is not None else {}).get("straightness", {})
    return {LINE_NAMES.get(n, n): (v, mc_u.get(n), "µm") for n, v in r.straightness_um().items()}


def as_left_section(doc: TypstDoc, found: tuple[LoadedRun, Any], left: tuple[LoadedRun, Any]) -> None:
    doc.heading("As found / as left")
    doc.key_values([("As found", f"{found[0].path.name} ({found[0].meta.get('created', '?')})"),
                    ("As left", f"{left[0].path.name} ({left[0].meta.get('created', '?')})")])
    a, b = _values(found[1]), _values(left[1])
    rows = []
    for name, (v1, u1, unit) in a.items():
        v2, u2, _ = b.get(name, (math.nan, None, unit))
        delta = v2 - v1
        ud = math.hypot(u1, u2) if u1 is not None and u2 is not None else None
        red = (v1 - v2) / v1 * 100.0 if math.isfinite(v1) and math.isfinite(v2) and v1 > 0 else math.nan
        label = name.replace("_up", " ↑").replace("_down", " ↓")
        rows.append((label, unit, _f(v1), _f(v2), _f(delta), _f(ud) if ud is not None else "not known",
                     f"{_f(red, 1)} %" if math.isfinite(red) else "—"))
    doc.table(("value", "unit", "as found", "as left", "delta (left − found)", "U of delta (k = 2)", "reduction"),
              rows)
    for label, run in (("As found", found[0]), ("As left", left[0])):
        rec = run_compensation(run.meta)
        if run.kind != "positioning":
            text = "not applicable (straightness run)"
        elif rec.get("active") is None:
            text = "not recorded (run written before the tool recorded it: unknown)"
        elif not rec.get("active"):
            text = "none"
        else:
            text = f"{rec.get('file', '?')} ({rec.get('format', '?')}), SHA-256 {rec.get('sha256', '?')}"
        doc.key_values([(f"{label}: compensation table active", text)])


def conformity_section(doc: TypstDoc, evaluation: Any, rule: str, left_evaluation: Any = None) -> None:
    doc.heading("Statement of conformity")
    shown = ([("as found", evaluation), ("as left", left_evaluation)] if left_evaluation is not None
             else [("outcome", evaluation)])
    if all(ev.verdict is None for _, ev in shown):
        doc.para("No specification was given (set-up [tolerance]): no statement of conformity is made.")
        return
    # positioning values: U = k·u_c with the run's --k (ISO 230-2's k); straightness: k = 2
    k = getattr(evaluation.result, "k", 2.0) if hasattr(evaluation.result, "axis") else 2.0
    doc.para(f"Decision rule: {rule} — {DECISION_RULE_NAMES[rule]}. U is the expanded uncertainty (k = {k:g}) "
             "of the value.")
    for label, ev in shown:
        v = ev.verdict
        if v is None:
            doc.para(f"{label}: no specification.")
            continue
        doc.para(f"{label.capitalize()}: {OUTCOME_WORDS[v.result]} (verdict {v.result.upper()})", bold=True)
        doc.table(("value", "specification", "measured", f"U (k = {k:g})", "outcome"),
                  [(c.quantity, f"≤ {c.tolerance:g} {UNIT.get(c.unit, c.unit)}",
                    f"{_f(c.value)} {UNIT.get(c.unit, c.unit)}" if c.value is not None else "not evaluated",
                    f"{_f(c.uncertainty)} {UNIT.get(c.unit, c.unit)}" if c.uncertainty is not None else "not known",
                    OUTCOME_WORDS[c.result]) for c in v.checks])


def closing_section(doc: TypstDoc, lab: Party, sha: str, left: LoadedRun | None) -> None:
    from ..report.build import tool_version

    doc.heading("Remarks")
    doc.para(RELATE_ONLY, bold=True)
    doc.para("This certificate shall not be reproduced except in full without the written approval of the "
             "issuing laboratory.")
    data = f"Data: run SHA-256 {sha} (SHA-256 of the bytes of run.json followed by the bytes of points.csv)"
    if left is not None:
        data += f"; as-left run SHA-256 {run_sha256(left.path)}"
    doc.para(data + f". Evaluated with guideway {tool_version()}.", size="8pt")
    doc.heading("Authorisation")
    doc.key_values([("Authorised by", lab.get("authoriser")), ("Role", lab.get("authoriser_role"))])
    doc.code("#v(1.2cm)\n#grid(columns: (7cm, 1fr), [#line(length: 100%, stroke: 0.5pt)\n#text(size: 8pt, "
             "\"Signature\")], [])")
    doc.code(f"#v(0.6cm)\n#align(center, text(weight: \"bold\", {lit('— ' + END_LINE + ' —')}))")


def parse_issue_date(text: str) -> datetime.date:
    try:
        return datetime.date.fromisoformat(text)
    except ValueError:
        raise UserError(f"--issue-date {text!r} must be a date YYYY-MM-DD") from None


__all__ = ["CertificateOptions", "build_certificate", "certificate_pdf", "parse_issue_date", "run_sha256"]
