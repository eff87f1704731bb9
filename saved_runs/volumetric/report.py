"""The HTML report of a volumetric grid: the error field per plane (colour map of |d| with arrows
of the in-plane error), extremes, per-axis and per-element contributions, the machine model."""

from __future__ import annotations

from datetime import UTC, datetime
from itertools import combinations
from typing import Any

import numpy as np

from processing.volumetric.evaluate import evaluate

from ..report.build import tool_version
from ..report.html import HtmlPage, figure_png
from .field import COMPONENT_COLUMNS, CONVENTIONS, ORIENTATION_COLUMNS, FieldResult

PLANE_POINTS = 21  # per axis in the field plots
ARROWS = 11        # arrows per axis


def _pose_text(pose: dict[str, float], units: dict[str, str]) -> str:
    return ", ".join(f"{k} = {v:g} {units[k]}" for k, v in pose.items())


def plane_figures(result: FieldResult) -> list[tuple[bytes, str]]:
    """One PNG per plane of two gridded axes, the other axes at mid-range / their fixed value (one
    gridded axis: the error components along it)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    model = result.model
    axes = {a.name: a for a in model.axes}
    out = []
    if len(result.gridded) == 1:  # one axis: the error components along it
        a = axes[result.gridded[0]]
        q = np.ravel(result.positions[a.name])
        fig, ax = plt.subplots(figsize=(6.4, 3.6))
        for i, label in enumerate(("dx", "dy", "dz")):
            ax.plot(q, result.error.position_um[:, i], marker=".", label=label)
        ax.plot(q, result.error.distance_um, color="black", label="|d|")
        ax.set_xlabel(f"{a.name} ({a.unit})")
        ax.set_ylabel("error (µm)")
        ax.legend(fontsize=8)
        fig.tight_layout()
        out.append((figure_png(fig), f"Error of the tool relative to the workpiece along {a.name} "
                                     f"({result.method}, {result.frame} frame)."))
    for a_name, b_name in combinations(result.gridded, 2):
        a, b = axes[a_name], axes[b_name]
        qa = np.linspace(a.range[0], a.range[1], PLANE_POINTS)
        qb = np.linspace(b.range[0], b.range[1], PLANE_POINTS)
        ga, gb = np.meshgrid(qa, qb, indexing="ij")
        positions: dict[str, Any] = {}
        for ax in model.axes:
            if ax.name in result.gridded:
                positions[ax.name] = float(np.mean(ax.range))
            else:
                positions[ax.name] = float(np.ravel(result.positions[ax.name])[0])
        held = {k: v for k, v in positions.items() if k not in (a_name, b_name)}
        positions[a_name], positions[b_name] = ga, gb
        err = evaluate(model, positions, result.machine.conditions, method=result.method, frame=result.frame)
        dist = err.distance_um
        fig, ax = plt.subplots(figsize=(6.4, 4.8))
        mesh = ax.pcolormesh(ga, gb, dist, shading="gouraud", cmap="viridis")
        fig.colorbar(mesh, ax=ax, label="|d| (µm)")
        step = max(1, PLANE_POINTS // ARROWS)
        ua, ub = err.position_um[..., a.axis] * a.sign, err.position_um[..., b.axis] * b.sign
        ax.quiver(ga[::step, ::step], gb[::step, ::step], ua[::step, ::step], ub[::step, ::step],
                  color="white", pivot="mid")
        ax.set_xlabel(f"{a_name} ({a.unit})")
        ax.set_ylabel(f"{b_name} ({b.unit})")
        where = _pose_text(held, {k.name: k.unit for k in model.axes}) or "no other axis"
        ax.set_title(f"{a_name}{b_name} plane, {where}", fontsize=9)
        fig.tight_layout()
        caption = (f"Error of the tool relative to the workpiece in the {a_name}{b_name} plane ({result.method}, "
                   f"{result.frame} frame): colour |d| (µm), arrows the error along {a_name} and {b_name} "
                   f"(not to scale); {where}.")
        out.append((figure_png(fig), caption))
    return out


def contribution_figure(result: FieldResult, top: int = 12) -> bytes:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    groups = sorted(result.groups.items(), key=lambda kv: -float(np.max(np.linalg.norm(kv[1], axis=-1))))
    elems = [s for s in result.elements if s.max_position_um > 0][:top]
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(9, 3.6))
    ax1.barh([g for g, _ in groups][::-1], [float(np.max(np.linalg.norm(d, axis=-1))) for _, d in groups][::-1])
    ax1.set_xlabel("max |contribution| (µm)")
    ax1.set_title("per axis / group", fontsize=9)
    ax2.barh([s.element.id for s in elems][::-1], [s.max_position_um for s in elems][::-1], color="tab:orange")
    ax2.set_xlabel("max |contribution| (µm)")
    ax2.set_title(f"largest {len(elems)} elements", fontsize=9)
    fig.tight_layout()
    return figure_png(fig)


def volumetric_page(result: FieldResult, summary: dict[str, Any], command: str = "") -> HtmlPage:
    m = result.machine
    model = result.model
    units = {a.name: a.unit for a in model.axes}
    page = HtmlPage(f"guideway volumetric report — {model.name or m.path.name}")
    page.heading("Summary")
    far = summary["max_distance_um"]
    page.key_values([
        ("machine file", str(m.path)),
        ("method", result.method + ("" if result.method == "exact" else " (linear in every element)")),
        ("frame", result.frame),
        ("conditions", f"{m.conditions['temperature_c']:g} °C, {m.conditions['time_h']:g} h"),
        ("grid", f"{summary['grid']['poses']} poses: {result.count} per axis over "
                 f"{', '.join(result.gridded)}" + (f"; fixed {_pose_text(summary['grid']['fixed'], units)}"
                                                   if summary["grid"]["fixed"] else "")),
        ("largest error |d|", f"{far['value']:.3f} µm at {_pose_text(far['pose'], units)}"),
        ("RMS of |d| over the grid", f"{summary['rms_distance_um']:.3f} µm"),
        ("elements", ", ".join(f"{k} {v}" for k, v in summary["elements"].items())),
    ] + ([("max |exact − first order|", f"{result.first_order_gap_um:.4f} µm")]
         if result.first_order_gap_um is not None else []))
    for note in m.notes:
        page.paragraph(f"Note: {note}", "note")
    page.heading("Error field")
    for png, caption in plane_figures(result):
        page.image(png, caption)
    page.heading("Extreme points", 3)
    rows = []
    for c in COMPONENT_COLUMNS + ORIENTATION_COLUMNS:
        x = summary["components"][c]
        rows.append((c, x["min"], _pose_text(x["min_pose"], units), x["max"], _pose_text(x["max_pose"], units)))
    page.table(("component", "min", "at", "max", "at"), rows, text_columns=(0, 2, 4))
    page.heading("Contributions (first order)", 3)
    page.image(contribution_figure(result), "Largest contribution to |d| over the grid per axis (its motion and "
                                            "location errors), squareness and thermal group, and per element.")
    page.table(("group", "max |d| (µm)", "RMS (µm)"),
               [(g, v["max"], v["rms"]) for g, v in summary["contributions_um"].items()])
    page.heading("Elements", 3)
    page.table(("element", "group", "body", "unit", "source", "max |d| (µm)", "max |ε| (µrad)"),
               [(s.element.id, s.element.group, s.element.body, s.element.unit, s.element.source,
                 s.max_position_um, s.max_orientation_urad) for s in result.elements],
               text_columns=(0, 1, 2, 3, 4))
    machine_section(page, result)
    page.heading("Conventions")
    page.paragraph(CONVENTIONS)
    generated = datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%SZ")
    page.paragraph(f"Produced by guideway {tool_version()} on {generated}" + (f" with: {command}" if command else ""),
                   "note footer")
    return page


def machine_section(page: HtmlPage, result: FieldResult) -> None:
    model = result.model
    page.heading("Machine model")
    page.key_values([("frame", f"primary {model.primary or '—'}, secondary {model.secondary or '—'}"),
                     ("tool offset (mm)", ", ".join(f"{v:g}" for v in model.tool_offset_mm))])
    rows = []
    for b in model.bodies:
        rows.append((b.chain, b.name, b.kind, b.direction_text(), ", ".join(f"{v:g}" for v in b.offset_mm),
                     f"{b.range[0]:g} … {b.range[1]:g} {b.unit}" if b.range else "—",
                     f"{b.reference:g}" if b.moving else "—"))
    page.table(("chain", "body", "type", "direction", "offset (mm)", "range", "reference"), rows,
               text_columns=(0, 1, 2, 3, 4, 5, 6))
