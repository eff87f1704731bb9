"""Report sections every run kind shares: run identity, instruments, environment."""

from __future__ import annotations

from typing import Any

import pandas as pd

from processing.columns import ENVIRONMENT

from ..runstore import LoadedRun
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
        ("status", m.get("status", "")),
        ("created (UTC)", m.get("created", "")),
        ("ended (UTC)", m.get("ended", "—")),
        ("machine", m.get("machine", "")),
        ("axis", m.get("axis", "") or m.get("setup", {}).get("axis_name", "")),
        ("operator", m.get("operator", "")),
        ("notes", m.get("notes", "")),
        ("points recorded", len(run.points)),
        ("run format version", m.get("version", "")),
    ])
    for w in run.warnings:
        page.paragraph(f"Warning: {w}", "note")


def instruments_section(page: HtmlPage, run: LoadedRun) -> None:
    instruments = run.meta.get("instruments") or {}
    page.heading("Instruments")
    if not instruments:
        page.paragraph("No instrument information recorded.", "note")
        return
    rows = []
    for role, info in instruments.items():
        details = ", ".join(f"{k}: {v}" for k, v in info.items() if k not in ("protocol", "endpoint"))
        rows.append((role, info.get("protocol", ""), info.get("endpoint", ""), details))
    page.table(("device", "protocol", "endpoint", "identity"), rows, text_columns=(0, 1, 2, 3))


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
    "Straightness profiles are heights (+Y) of the surface at the sensor's sample point relative to the first "
    "station. See docs/conventions.md."
)


def conventions_section(page: HtmlPage) -> None:
    page.heading("Conventions")
    page.paragraph(CONVENTIONS_TEXT)
