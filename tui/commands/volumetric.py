"""``guideway volumetric MACHINE.toml``: the volumetric error model of a machine (docs/volumetric.md).

Three modes: a grid of the workspace written to ``--out DIR`` (CSV, summary, HTML report),
``--at`` one pose (with every element's contribution), ``--export linuxcnc|csv`` per-axis tables.
"""

from __future__ import annotations

import argparse
import json
import math
import shlex
import sys
from pathlib import Path

DEFAULT_GRID = 11
FRAME_CHOICES = ("workpiece", "machine")
EXPORT_CHOICES = ("linuxcnc", "csv")
TOP_ELEMENTS = 8


def run(args: argparse.Namespace) -> int:
    from saved_runs.errors import UserError
    from saved_runs.volumetric.machine_file import load_machine

    if args.at is not None and args.export is not None:
        raise UserError("--at and --export cannot be combined; run them separately")
    if args.at is None and args.out is None:
        raise UserError("give --out DIR (grid or --export) or --at POSITIONS")
    if args.json and args.at is None:
        raise UserError("--json goes with --at (the grid writes DIR/summary.json)")
    if args.at is not None and (args.out is not None or args.set):
        raise UserError(f"--at prints one pose; {'--out' if args.out is not None else '--set'} goes with the grid "
                        "or --export (run them separately)")
    for option, value in (("--temperature-c", args.temperature_c), ("--time-h", args.time_h)):
        if value is not None and not math.isfinite(value):
            raise UserError(f"{option} {value}: give a finite number")
    machine = load_machine(args.machine, conditions={"temperature_c": args.temperature_c, "time_h": args.time_h})
    method = "exact" if args.exact else "first-order"
    if args.at is not None:
        return _at(machine, args, method)
    from saved_runs.volumetric.field import parse_settings

    fixed = parse_settings(machine.model, args.set or [])
    if args.export is not None:
        return _export(machine, args, method, fixed)
    return _grid(machine, args, method, fixed)


def _notes(machine) -> None:  # noqa: ANN001
    for note in machine.notes:
        print(f"guideway: note: {note}", file=sys.stderr)


def _at(machine, args: argparse.Namespace, method: str) -> int:  # noqa: ANN001
    from saved_runs.volumetric.field import at_pose

    obj = at_pose(machine, args.at, method=method, frame=args.frame)
    if args.json:
        json.dump(obj, sys.stdout, allow_nan=False)
        sys.stdout.write("\n")
        return 0
    _notes(machine)
    units = obj["units"]
    pose = ", ".join(f"{k} = {v:g} {units[k]}" for k, v in obj["pose"].items())
    e = obj["error"]
    print(f"{machine.model.name or machine.path}: error at {pose} ({method}, {args.frame} frame)")
    print(f"  position    dx {_signed(e['dx_um'], 9)}  dy {_signed(e['dy_um'], 9)}  dz {_signed(e['dz_um'], 9)}  "
          f"|d| {e['d_um']:8.3f} um")
    print(f"  orientation ex {_signed(e['ex_urad'], 9)}  ey {_signed(e['ey_urad'], 9)}  ez {_signed(e['ez_urad'], 9)}  "
          f"|e| {e['e_urad']:8.3f} urad")
    print(f"  largest contributions (first order), of {len(obj['contributions'])} elements:")
    for r in obj["contributions"][:TOP_ELEMENTS]:
        print(f"    {r['element']:<8} {_signed(r['value'], 10)} {r['unit']:<5} -> dx {_signed(r['dx_um'], 8)} "
              f"dy {_signed(r['dy_um'], 8)} dz {_signed(r['dz_um'], 8)} um, |e| {r['e_urad']:.3f} urad   {r['source']}")
    return 0


def _signed(v: float, width: int) -> str:
    """``v`` to 3 decimals with its sign; a value that rounds to zero is +0.000 (not -0.000 from -1e-17)."""
    return f"{round(v, 3) + 0.0:+{width}.3f}"


def _grid(machine, args: argparse.Namespace, method: str, fixed: dict[str, float]) -> int:  # noqa: ANN001
    from saved_runs.volumetric.field import evaluate_field, grid_positions
    from saved_runs.volumetric.outputs import write_field

    from .progress import progress_display, short

    _notes(machine)
    with progress_display() as stages:
        gridded, positions = grid_positions(machine.model, args.grid, fixed)
        stages.stage(f"evaluating {args.grid ** len(gridded)} poses")
        result = evaluate_field(machine, positions, method=method, frame=args.frame, gridded=gridded,
                                count=args.grid)
        command = shlex.join(["guideway", "volumetric", *sys.argv[2:]]) if sys.argv[1:2] == ["volumetric"] else ""
        summary = write_field(result, args.out, command=command, progress=stages.stage(f"writing {short(args.out)}"))
    far = summary["max_distance_um"]
    units = {a.name: a.unit for a in machine.model.axes}
    print(f"{summary['grid']['poses']} poses ({args.grid} per axis over {', '.join(gridded)}), {method}, "
          f"{args.frame} frame")
    print(f"  largest |d| {far['value']:.3f} um at " + ", ".join(f"{k} = {v:g} {units[k]}"
                                                                  for k, v in far["pose"].items()))
    print(f"  RMS |d| {summary['rms_distance_um']:.3f} um")
    if summary["exact_minus_first_order_um"] is not None:
        print(f"  max |exact - first order| {summary['exact_minus_first_order_um']:.4f} um")
    print("  largest contributions: " + ", ".join(f"{r['element']} {r['max_position_um']:.3f} um"
                                                  for r in summary["element_ranking"][:5]))
    print(f"results written to {args.out} (volumetric.csv, contributions.csv, summary.json, report.html)")
    return 0


def _export(machine, args: argparse.Namespace, method: str, fixed: dict[str, float]) -> int:  # noqa: ANN001
    from saved_runs.volumetric.export import export_model

    from .progress import progress_display

    _notes(machine)
    with progress_display() as stages:
        stages.stage(f"building the {args.export} tables")
        ex = export_model(machine, args.export, args.out, count=args.grid, fixed=fixed, method=method)
    for t, r in zip(ex.tables, ex.residuals, strict=True):
        print(f"{t.axis}: {len(t.position)} points, error {t.error.min():+.3f} … {t.error.max():+.3f} "
              f"{t.error_unit}; along {t.axis} over the grid: max |e| {r.before:.3f} -> {r.after:.3f} {r.unit} "
              "after the table")
    print(f"position error the per-axis tables cannot hold (cross terms, other directions): up to "
          f"{ex.unheld_position_um:.3f} um over the grid")
    big = [c for c in ex.cross if c.max_abs >= 0.01 * (ex.cross[0].max_abs if ex.cross else 0)][:TOP_ELEMENTS]
    if big:
        print("largest cross terms (not held by any per-axis table):")
        for c in big:
            target = f"along {c.target}" if c.target not in ("position", "orientation") else f"{c.target} (no axis)"
            print(f"  {c.element:<8} {target:<24} up to {c.max_abs:.3f} {c.unit}")
    for note in ex.notes:
        print(f"note: {note}")
    print(f"written to {args.out}: " + ", ".join(p.name for p in ex.files))
    return 0


def register(sub) -> None:  # noqa: ANN001
    vo = sub.add_parser("volumetric", help="volumetric error model of a machine from its runs (MACHINE.toml)",
                        description="Evaluate the multi-body volumetric error model of a machine file: over a "
                                    "grid (--out DIR), at one pose (--at), or as per-axis compensation tables "
                                    "(--export). See docs/volumetric.md.")
    vo.add_argument("machine", type=Path, help="machine file (see docs/machine-example.toml)")
    vo.add_argument("--out", type=Path, default=None, help="directory for the grid results or the exported tables")
    vo.add_argument("--grid", type=int, default=DEFAULT_GRID, metavar="N",
                    help=f"points per prismatic axis over its range (default {DEFAULT_GRID})")
    vo.add_argument("--exact", action="store_true",
                    help="exact product of the error transforms (default: first order, linear in every element)")
    vo.add_argument("--at", nargs="+", default=None, metavar="POS",
                    help="one pose: positions in axis order (prismatic by name, then rotary, e.g. X Y Z B C) or "
                         "AXIS=VALUE; axes not given stay at their reference")
    vo.add_argument("--json", action="store_true", help="with --at: print one JSON object")
    vo.add_argument("--export", choices=EXPORT_CHOICES, default=None,
                    help="per-axis compensation tables (and cross-terms.csv) into --out DIR")
    vo.add_argument("--set", action="append", default=None, metavar="AXIS=VALUE",
                    help="hold an axis at a position in the grid (repeatable; rotary axes default to their "
                         "reference)")
    vo.add_argument("--frame", choices=FRAME_CHOICES, default="workpiece",
                    help="frame of the error vectors (default: workpiece)")
    vo.add_argument("--temperature-c", type=float, default=None, help="temperature for the thermal elements")
    vo.add_argument("--time-h", type=float, default=None, help="time (h) for the thermal elements")
    vo.set_defaults(func=run)
