"""``guideway compare RUN_A RUN_B [--json] [--report FILE]``: a run before and after (a compensation, a
repair, a quarter of wear), the change at every target or station with its uncertainty (docs/compare.md)."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from .process import add_evaluator_options, evaluator_options, warn_about_run


def run(args: argparse.Namespace) -> int:
    from fleet.compare.compare import compare_runs

    options = evaluator_options(args)
    comparison = compare_runs(args.run_a, args.run_b, any_axis=args.any_axis, **options)
    for label, loaded in zip("AB", comparison.runs, strict=True):
        warn_about_run(loaded, f"comparing run {label}'s")
    written = None
    if args.report is not None:
        from fleet.compare.report import compare_command, write_comparison_report

        command = compare_command(args.run_a, args.run_b, args.report, {**options, "any_axis": args.any_axis})
        written = write_comparison_report(comparison, args.report, command=command)
    if args.json:
        json.dump(comparison.to_dict(), sys.stdout, allow_nan=False)
        sys.stdout.write("\n")
        if written is not None:
            print(f"report written to {written}", file=sys.stderr)
    else:
        from fleet.compare.text import print_comparison

        print_comparison(comparison, sys.stdout)
        if written is not None:
            print(f"report written to {written}")
    return 0


def register(sub) -> None:  # noqa: ANN001
    p = sub.add_parser("compare", help="compare two runs of one axis: the change at every target or station",
                       description="Evaluate two saved runs of the same kind as process does (nothing is written "
                                   "into them) and show the change B - A per target and direction (positioning) or "
                                   "per station against a common least-squares line (straightness), with the "
                                   "expanded uncertainty of the change, and the values side by side "
                                   "(docs/compare.md).")
    p.add_argument("run_a", type=Path, metavar="RUN_A", help="the run before (the reference)")
    p.add_argument("run_b", type=Path, metavar="RUN_B", help="the run after")
    p.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    p.add_argument("--report", type=Path, default=None, metavar="FILE",
                   help="write an HTML report with the overlay plot and the tables")
    p.add_argument("--any-axis", action="store_true",
                   help="compare runs that name different axes (refused otherwise)")
    add_evaluator_options(p)
    p.set_defaults(func=run)
