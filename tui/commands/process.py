"""``guideway process RUN_DIR``: evaluate a saved run and write its results."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path


def run(args: argparse.Namespace) -> int:
    from acquisition.evaluate import process_run_dir

    run_, result = process_run_dir(args.run_dir)
    for w in run_.warnings:
        print(f"guideway: warning: {w}", file=sys.stderr)
    if run_.meta.get("status") != "complete":
        print(f"guideway: warning: run status is {run_.meta.get('status')!r}; processing the "
              f"{len(run_.points)} point(s) recorded", file=sys.stderr)
    if not args.no_write:
        result.write(run_.path / "results")
    if args.json:
        json.dump(result.to_dict(), sys.stdout, allow_nan=False)
        sys.stdout.write("\n")
    else:
        result.print_summary(sys.stdout)
        if not args.no_write:
            print(f"results written to {run_.path / 'results'}")
    return 0


def register(sub) -> None:  # noqa: ANN001
    pr = sub.add_parser("process", help="evaluate a saved run and write its results")
    pr.add_argument("run_dir", type=Path)
    pr.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    pr.add_argument("--no-write", action="store_true", help="do not write results/")
    pr.set_defaults(func=run)
