"""Report sections every run kind shares: run identity, instruments, environment."""

from __future__ import annotations

from typing import Any

import pandas as pd

from processing.columns import ENVIRONMENT

from ..store.reader import LoadedRun
from .html import HtmlPage

ENV_LABELS = {
    "air_temp_c": "air temperature (°C)",
    "air_pressure_hpa": "air pressure (hPa)",
    "humidity_pct": "relative humidity (%RH)",
    "material_temp_c": "material temperature (°C)",
}


def environment_summary(points: pd.DataFrame) -> list[dict[str, Any]]:
    """min / max / mean / start / end of each environment column present (NaN-aware)."""
    rows = []
    for col in ENVIRONMENT:
        if col not in points:
            continue
        v = points[col].astype(float).dropna()
        if v.empty:
            continue
        rows.append({"quantity": ENV_LABELS[col], "column": col, "min": float(v.min()), "max": float(v.max()),
                     "mean": float(v.mean()), "start": float(v.iloc[0]), "end": float(v.iloc[-1])})
    return rows


def run_section(page: HtmlPage, run: LoadedRun) -> None:
    m = run.meta
    page.heading("Run")
    page.key_values([
        ("run directory", str(run.path)),
        ("kind", m.get("kind", "")),
        ("status", m.get("status", "") + (f" ({m['end_reason']})" if m.get("end_reason") else "")),
        ("created (UTC)", m.get("created", "")),
        ("ended (UTC)", m.get("ended", "—")),
        ("machine", m.get("machine", "")),
        ("axis", m.get("axis", "") or m.get("setup", {}).get("axis_name", "")),
        ("operator", m.get("operator", "")),
        ("notes", m.get("notes", "")),
        ("points recorded / planned", f"{len(run.points)} / {planned_points(m) or '—'}"),
        ("run format version", m.get("version", "")),
    ])
    for w in run.warnings:
        page.paragraph(f"Warning: {w}", "note")


# What the devices report about themselves (Modbus read device identification of the
# controller; GETINFO of the ILD1420); anything else in run.json's instruments comes from the
# driver or the set-up (a family name for a sensor without an identity query, a station number).
DEVICE_IDENTITY_KEYS = {"vendor", "product_code", "revision", "vendor_url", "product", "model",
                        "user_application_name", "serial"}


def reported_identity(role: str, info: dict[str, Any]) -> tuple[list[tuple[str, Any]], list[tuple[str, Any]]]:
    """(what the device reported, what the driver / set-up says) of one run.json instrument."""
    from drivers.sensor_families import SENSOR_DRIVERS

    rest = [(k, v) for k, v in info.items() if k not in ("protocol", "endpoint")]
    if role == "sensor":
        driver = SENSOR_DRIVERS.get(str(info.get("protocol", "")))
        asks = bool(getattr(driver, "identity_query", False))
        return (rest, []) if asks else ([], rest)
    if role == "interferometer":
        return [kv for kv in rest if kv[0] in DEVICE_IDENTITY_KEYS], [kv for kv in rest if kv[0] not in
                                                                      DEVICE_IDENTITY_KEYS]
    return [], rest  # the XY-MD02 transmitter has no identity registers


def instruments_section(page: HtmlPage, run: LoadedRun) -> None:
    instruments = run.meta.get("instruments") or {}
    page.heading("Instruments")
    if not instruments:
        page.paragraph("No instrument information recorded.", "note")
        return
    rows = []
    for role, info in instruments.items():
        reported, other = reported_identity(role, info)
        rows.append((role, info.get("protocol", ""), info.get("endpoint", ""),
                     ", ".join(f"{k}: {v}" for k, v in reported) or "not reported by the device",
                     ", ".join(f"{k}: {v}" for k, v in other) or "—"))
    page.table(("device", "protocol", "endpoint", "identity reported by the device", "driver / set-up"), rows,
               text_columns=(0, 1, 2, 3, 4))
    page.paragraph("The protocol is what the tool spoke; the identity is what the device answered to its "
                   "identification query. A protocol without an identity query says nothing about which device "
                   "answered: the driver / set-up column names only the family it was configured for.", "note")


SIMULATOR_VENDOR = "guideway-sim"  # what the simulated controller answers to device identification


def simulated(meta: dict[str, Any]) -> str | None:
    """Why the run is a simulation (None for a run on real devices): run.json ``simulation``
    (written by ``--simulate`` and ``demo``), or a controller identifying as the simulator."""
    sim = meta.get("simulation")
    if isinstance(sim, dict):
        noise = sim.get("noise")
        return (f"simulated devices (seed {sim.get('seed', '?')}, instrument noise "
                f"{'on' if noise else 'off' if noise is not None else '?'})")
    for info in (meta.get("instruments") or {}).values():
        if isinstance(info, dict) and info.get("vendor") == SIMULATOR_VENDOR:
            return "the controller identified itself as the guideway simulator"
    return None


def simulated_banner(page: HtmlPage, run: LoadedRun) -> None:
    why = simulated(run.meta)
    if why is not None:
        page.banner(f"SIMULATED RUN — not a measurement of a machine ({why})")


def environment_section(page: HtmlPage, run: LoadedRun) -> None:
    page.heading("Environment")
    rows = environment_summary(run.points)
    if not rows:
        page.paragraph("No environment values recorded.", "note")
        return
    page.table(("quantity", "min", "max", "mean", "start", "end"),
               [(r["quantity"], r["min"], r["max"], r["mean"], r["start"], r["end"]) for r in rows])


CONVENTIONS_TEXT = (
    "Axes: X = travel, Y = up, Z = X × Y; roll εx about X, yaw εy about Y, pitch εz about Z, right-hand rule, "
    "R = Rz(εz)·Ry(εy)·Rx(εx). Deviations are errors (measured − nominal), not corrections. "
)
KIND_CONVENTIONS = {
    "straightness": "Straightness profiles are heights (+Y) of the surface at the sensor's sample point relative to "
                    "the first station; each straightness value names its reference line.",
    "positioning": "Positioning deviations x_ij = actual − target (µm, rotary axes arcsec); ↑ = approach in the "
                   "positive direction, ↓ = negative; compensation-table signs: docs/compensation.md.",
}


def conventions_section(page: HtmlPage, kind: str = "") -> None:
    page.heading("Conventions")
    page.paragraph(CONVENTIONS_TEXT + KIND_CONVENTIONS.get(kind, "") + " See docs/conventions.md.")


def planned_points(meta: dict[str, Any]) -> int | None:
    """Points the run's plan asked for (None if run.json does not say).

    Straightness: ``setup.stations`` (× 2 with ``setup.return_pass``); positioning:
    targets × ``setup.runs`` (default 5) × 2 directions."""
    setup = meta.get("setup") or {}
    try:
        if meta.get("kind") == "straightness":
            stations = setup.get("stations")
            return int(stations) * (2 if setup.get("return_pass") else 1) if stations is not None else None
        if meta.get("kind") == "positioning":
            targets = setup.get("targets_mm", setup.get("targets_deg"))
            return len(targets) * int(setup.get("runs", 5)) * 2 if targets else None
    except (TypeError, ValueError):
        return None
    return None


def status_section(page: HtmlPage, run: LoadedRun) -> None:
    """A boxed notice for runs that are not complete (aborted, or in progress = crashed)."""
    status = run.meta.get("status", "")
    if status == "complete":
        return
    planned = planned_points(run.meta)
    recorded = f"{len(run.points)} of {planned} planned points" if planned else f"{len(run.points)} points"
    reason = run.meta.get("end_reason")
    page.alert(f"Run status: {status or 'unknown'}" + (f" ({reason})" if reason else "") +
               f". {recorded} recorded; the results below cover only the points recorded.")


def out_of_range_section(page: HtmlPage, evaluation: Any) -> None:
    """A boxed notice listing the values outside the set-up's validation limits that were
    evaluated anyway (``--accept-out-of-range``)."""
    found = getattr(evaluation, "out_of_range", ())
    if not found:
        return
    page.alert(f"{len(found)} value(s) outside the set-up's validation limits were evaluated anyway "
               "(--accept-out-of-range): the results below may be meaningless.")
    page.table(("point", "column", "value", "limit"), [(f.where, f.column, f.value, f.limit) for f in found],
               digits=6, text_columns=(0, 1, 3))


def verdict_section(page: HtmlPage, verdict: Any, what: str) -> None:
    """The pass/fail verdict against the set-up's [tolerance] (saved_runs.evaluation.tolerance), or why
    there is none; ``what`` names the keys a tolerance would need."""
    if verdict is None:
        page.paragraph(f"No tolerance in the set-up ([tolerance] {what}): no pass/fail verdict.", "note")
        return
    cls = {"pass": "verdict-pass", "fail": "verdict-fail"}.get(verdict.result, "verdict-open")
    why = getattr(verdict, "reason", "")  # NOT EVALUATED says why (one run per direction, a gap in the run)
    page.paragraph(f"Verdict: {verdict.result.upper()}" + (f": {why}" if why else ""), f"headline {cls}")
    if getattr(verdict, "incomplete", ""):  # a gap in the run: no PASS (saved_runs/store/plan.py)
        page.paragraph(f"Run incomplete: {verdict.incomplete}; the verdict cannot be PASS.", "note")
    from ..evaluation.tolerance import DECISION_RULE_NAMES

    rule = getattr(verdict, "rule", "simple")
    page.paragraph(f"Decision rule: {rule} — {DECISION_RULE_NAMES.get(rule, rule)}.", "note")
    rows = [(c.quantity, c.value, c.tolerance, UNIT_LABELS.get(c.unit, c.unit), c.uncertainty,
             c.result + (" (within U of the limit: not proven, ISO 14253-1)" if c.within_uncertainty and
                         rule == "simple" else "")
             + (" (U of this value not known)" if c.result == "not decidable" and c.uncertainty is None else ""))
            for c in verdict.checks]
    page.table(("quantity", "value", "tolerance", "unit", "U, k = 2", "result"), rows, text_columns=(0, 3, 5))


UNIT_LABELS = {"um": "µm", "arcsec": "arcsec", "mm": "mm", "deg": "°", "urad": "µrad"}
