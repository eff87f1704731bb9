"""``guideway export RUN_DIR --format ...``: CNC compensation table from a positioning run."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path


def run(args: argparse.Namespace) -> int:
    from saved_runs.errors import UserError
    from saved_runs.export.build import export_run, write_export
    from saved_runs.export.options import ExportOptions

    options = ExportOptions(
        fmt=args.format, model=args.model, mode=args.mode, step=args.step, tolerance=args.tolerance,
        initial_maxima=args.initial_knots, degree=args.degree, axis=args.axis,
        reference_position=args.reference_position, linuxcnc_type=args.linuxcnc_type,
        fanuc_magnification=args.fanuc_magnification, fanuc_detection_unit_um=args.fanuc_detection_unit,
        fanuc_first_point=args.fanuc_first_point, fanuc_reference_point=args.fanuc_reference_point,
        fanuc_negative_table=args.fanuc_negative_table, fanuc_reference_direction=args.fanuc_reference_direction,
        siemens_axis=args.siemens_axis, siemens_encoder=args.siemens_encoder, siemens_modulo=args.siemens_modulo,
        siemens_max_points=args.siemens_max_points,
    )
    to_stdout = args.out is not None and str(args.out) == "-"
    if to_stdout and args.json:
        raise UserError("--json prints the residuals on stdout; write the table to a file (--out FILE) "
                        "or use the default")
    info = sys.stderr if to_stdout or args.json else sys.stdout
    out = None
    if to_stdout:
        run_, export = export_run(args.run_dir, options, accept_out_of_range=args.accept_out_of_range)
    else:
        run_, export, out = write_export(args.run_dir, options, args.out, accept_out_of_range=args.accept_out_of_range)
    for w in run_.warnings:
        print(f"guideway: warning: {w}", file=sys.stderr)
    if to_stdout:
        sys.stdout.write(export.text)
    else:
        first, last = export.table.position[0], export.table.position[-1]
        step = "" if export.grid_step is None else f", step {round(export.grid_step, 9):.12g} {export.position_unit}"
        print(f"{args.format} table ({len(export.table)} points, {first:g} … {last:g} {export.position_unit}{step}, "
              f"model {args.model}) written to {out}", file=info)
    from saved_runs.export.load import export_load_instructions

    axis = args.axis or str((run_.meta.get("setup") or {}).get("axis_name") or run_.meta.get("axis") or "X")
    load = export_load_instructions(export, out, options, axis)
    if args.json:
        json.dump({**export.to_dict(), "out": None if out is None else str(out), "load": load}, sys.stdout,
                  allow_nan=False)
        sys.stdout.write("\n")
        return 0
    for note in export.notes:
        print(note, file=info)
    print(export.residual_text(), file=info)
    print("load it (the tool writes nothing into the controller):", file=info)
    from saved_runs.export.load import numbered

    for line in numbered(load):
        print(f"  {line}", file=info)
    return 0


def register(sub) -> None:  # noqa: ANN001
    from saved_runs.export.options import DEFAULT_POLYNOMIAL_DEGREE, FORMATS, MODEL_NAMES, MODES

    ex = sub.add_parser("export", help="write a CNC compensation table from a positioning run",
                        description="Model the per-target mean deviations of a positioning run and write a "
                                    "compensation table; prints every model's residual after compensation.")
    ex.add_argument("run_dir", type=Path)
    ex.add_argument("--format", required=True, choices=FORMATS)
    ex.add_argument("--model", default="linear", choices=MODEL_NAMES)
    ex.add_argument("--mode", choices=MODES, default=None,
                    help="separate +/- tables, or one mean table + backlash (default: bidirectional; "
                         "siemens: backlash)")
    ex.add_argument("--json", action="store_true",
                    help="print the residuals (comparison, table as written, cross-validation) as one JSON "
                         "object on stdout (the table is written to its file)")
    ex.add_argument("--accept-out-of-range", action="store_true",
                    help="use readings further from their target than the set-up allows instead of refusing")
    ex.add_argument("--out", type=Path, default=None,
                    help="output file ('-' = stdout; default RUN_DIR/results/compensation-FORMAT.*)")
    ex.add_argument("--step", type=float, default=None,
                    help="equidistant grid step, mm or deg (default: model nodes; fanuc/siemens: mean target "
                         "spacing rounded to 0.001)")
    ex.add_argument("--tolerance", type=float, default=None,
                    help="spline tolerance / segment threshold, um or arcsec (default max|e|/20)")
    ex.add_argument("--initial-knots", type=int, default=None,
                    help="spline: curvature maxima taken as initial knots, largest first (default all)")
    ex.add_argument("--degree", type=int, default=DEFAULT_POLYNOMIAL_DEGREE,
                    help="polynomial degree (lowered to targets - 2, at least 1, with fewer targets)")
    ex.add_argument("--axis", default=None, help="axis name (default run.json setup.axis_name)")
    ex.add_argument("--reference-position", type=float, default=None,
                    help="fanuc: reference position, mm (default first target); siemens: table zero point")
    ex.add_argument("--linuxcnc-type", type=int, choices=(0, 1), default=1, help="COMP_FILE_TYPE")
    ex.add_argument("--fanuc-magnification", type=int, default=1, help="parameter 3623")
    ex.add_argument("--fanuc-detection-unit", type=float, default=1.0, help="detection unit, um")
    ex.add_argument("--fanuc-first-point", type=int, default=0,
                    help="number of the first compensation point of this axis (3621)")
    ex.add_argument("--fanuc-reference-point", type=int, default=None, help="parameter 3620 (overrides first point)")
    ex.add_argument("--fanuc-negative-table", type=int, default=None,
                    help="parameter 3626, first point of the negative-direction table (default after 3622)")
    ex.add_argument("--fanuc-reference-direction", type=int, choices=(1, -1), default=1,
                    help="reference-return direction")
    ex.add_argument("--siemens-axis", default=None, help="machine axis in $AA_ENC_COMP[e,N,AX] (default AXIS1)")
    ex.add_argument("--siemens-encoder", type=int, choices=(0, 1), default=0, help="measuring system e")
    ex.add_argument("--siemens-modulo", action="store_true", help="modulo table (rotary, 360 deg span)")
    ex.add_argument("--siemens-max-points", type=int, default=None, help="MD38000 MM_ENC_COMP_MAX_POINTS")
    ex.set_defaults(func=run)
