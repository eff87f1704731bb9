"""``guideway report RUN_DIR``: a printable, self-contained HTML report of a saved run."""

from __future__ import annotations

import argparse
from pathlib import Path

from .process import add_evaluator_options, evaluator_options, warn_about_run


def run(args: argparse.Namespace) -> int:
    from saved_runs.report.build import build_report
    from saved_runs.store.reader import load_run

    warn_about_run(load_run(args.run_dir), "the report covers the")
    path = build_report(args.run_dir, out=args.out, **evaluator_options(args))
    print(f"report written to {path}")
    return 0


def register(sub) -> None:  # noqa: ANN001
    rp = sub.add_parser("report", help="write a printable HTML report of a saved run",
                        description="Evaluate a saved run and write one self-contained HTML file (plots "
                                    "embedded) with the results, instruments, environment and conventions.")
    rp.add_argument("run_dir", type=Path)
    rp.add_argument("--out", type=Path, default=None, help="HTML file to write (default RUN_DIR/results/report.html)")
    add_evaluator_options(rp)
    rp.set_defaults(func=run)
