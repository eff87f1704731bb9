"""``guideway verify AS_FOUND AS_LEFT [--json] [--report FILE]``: did the table exported from AS_FOUND do what
the export predicted, measured again in AS_LEFT with the table active (docs/compensation.md, "Verify")."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from .process import evaluator_options, warn_about_run


def run(args: argparse.Namespace) -> int:
    from fleet.verify.verify import verify_runs

    options = evaluator_options(args)
    verification = verify_runs(args.as_found, args.as_left, **options)
    for label, loaded in zip(("AS_FOUND", "AS_LEFT"), verification.comparison.runs, strict=True):
        warn_about_run(loaded, f"verifying {label}'s")
    written = None
    if args.report is not None:
        from fleet.verify.report import verify_command, write_verification_report

        command = verify_command(args.as_found, args.as_left, args.report, options)
        written = write_verification_report(verification, args.report, command=command)
    if args.json:
        json.dump(verification.to_dict(), sys.stdout, allow_nan=False)
        sys.stdout.write("\n")
        if written is not None:
            print(f"report written to {written}", file=sys.stderr)
    else:
        from fleet.verify.text import print_verification

        print_verification(verification, sys.stdout)
        if written is not None:
            print(f"report written to {written}")
    return 0


def register(sub) -> None:  # noqa: ANN001
    from saved_runs.evaluation.options import EDITIONS

    p = sub.add_parser("verify", help="check an as-left run against the table exported from the as-found run",
                       description="AS_LEFT was measured with a compensation table active: say which table (the one "
                                   "exported from AS_FOUND, by its SHA-256, or which other), and per ISO 230-2 value "
                                   "found, left, predicted (AS_FOUND with the table applied as its controller applies "
                                   "it) and the reduction in %, with uncertainties; flag gains smaller than the "
                                   "repeatability or the drift between the runs (docs/compensation.md).")
    p.add_argument("as_found", type=Path, metavar="AS_FOUND", help="the run the table was exported from")
    p.add_argument("as_left", type=Path, metavar="AS_LEFT", help="the run measured with the table active")
    p.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    p.add_argument("--report", type=Path, default=None, metavar="FILE",
                   help="write an HTML report with the before/after overlay and the tables")
    p.add_argument("--k", type=float, default=None, help="ISO 230-2 coverage factor (default 2)")
    p.add_argument("--edition", choices=EDITIONS, default=None,
                   help="ISO 230-2 edition recorded (default ISO 230-2:2014)")
    p.add_argument("--accept-out-of-range", action="store_true",
                   help="evaluate values outside the set-up's validation limits instead of refusing a run")
    p.set_defaults(func=run, method=None, mc_trials=None)
