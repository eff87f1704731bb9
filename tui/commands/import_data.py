"""``guideway import positioning DATA.csv --out RUN_DIR``: measured data from elsewhere as a run."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def run_positioning(args: argparse.Namespace) -> int:
    from saved_runs.importing.positioning import (
        MAX_PROBLEMS_SHOWN,
        ImportProblems,
        PositioningImport,
        import_positioning,
    )

    opts = PositioningImport(
        axis_type=args.axis_type, compensated=args.compensated, refractive_index_assumed=args.index_assumed,
        wavelength_nm=args.wavelength_nm, co2_ppm=args.co2_ppm, expansion_ppm_per_k=args.expansion_ppm_per_k,
        dead_path_mm=args.dead_path_mm, index_equation=args.equation, axis_name=args.axis, machine=args.machine)
    try:
        out, n = import_positioning(args.csv, args.out, opts,
                                    warn=lambda w: print(f"guideway: warning: {w}", file=sys.stderr))
    except ImportProblems as exc:
        for p in exc.problems[:MAX_PROBLEMS_SHOWN]:
            print(f"guideway: error: {p}", file=sys.stderr)
        if len(exc.problems) > MAX_PROBLEMS_SHOWN:
            print(f"guideway: error: ... and {len(exc.problems) - MAX_PROBLEMS_SHOWN} more problem(s)",
                  file=sys.stderr)
        return 2
    print(f"imported {n} point(s) into {out}; evaluate with: guideway process {out}")
    return 0


def register(sub) -> None:  # noqa: ANN001
    from saved_runs.evaluation.air import DEFAULT_EQUATION, EQUATIONS

    pi = sub.add_parser("import", help="import measured data from a CSV file as a run directory")
    kinds = pi.add_subparsers(dest="import_kind", required=True, parser_class=type(pi))
    pp = kinds.add_parser("positioning", help="ISO 230-2 positioning data: run, direction, target_mm, reading_mm")
    pp.add_argument("csv", type=Path, help="CSV file with a header line (see docs/positioning.md)")
    pp.add_argument("--out", type=Path, required=True, help="new run directory to write")
    pp.add_argument("--axis-type", choices=("linear", "rotary"), default="linear")
    pp.add_argument("--compensated", action="store_true",
                    help="readings are already environment-compensated (no air/material correction)")
    pp.add_argument("--index-assumed", type=float, default=1.0,
                    help="air index the controller applied to the readings (default 1.0 = vacuum counts)")
    pp.add_argument("--equation", choices=EQUATIONS, default=DEFAULT_EQUATION, help="air-index equation")
    pp.add_argument("--wavelength-nm", type=float, default=None, help="vacuum wavelength (default 632.991)")
    pp.add_argument("--co2-ppm", type=float, default=None, help="CO2 content (default 450)")
    pp.add_argument("--expansion-ppm-per-k", type=float, default=None,
                    help="expansion coefficient of the axis (ppm/K): normalise to 20 C with material_temp_c")
    pp.add_argument("--dead-path-mm", type=float, default=None, help="dead path at the datum (mm)")
    pp.add_argument("--axis", default="", help="axis name, e.g. X")
    pp.add_argument("--machine", default="", help="machine name")
    pp.set_defaults(func=run_positioning)
