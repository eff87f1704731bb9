"""``guideway diagnose RUN_DIR --model MODEL.toml [--json] [--report FILE] [--out MODEL_OUT.toml]``:
find the physical effect the model lacks, add it and show the gap shrink."""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

from .process import warn_about_run


def run(args: argparse.Namespace) -> int:
    # The fits are small (at most n x ~110): a BLAS thread pool only contends with itself and other
    # processes (benchmarks/bench_diagnose.py); one thread unless the user says otherwise.  Set before
    # numpy is first imported by this command.
    for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(var, "1")
    from saved_runs.diagnosis.diagnose import diagnose_run, write_model
    from saved_runs.store.reader import load_run

    warn_about_run(load_run(args.run_dir), "diagnosing the")
    diagnosis = diagnose_run(args.run_dir, args.model, accept_out_of_range=args.accept_out_of_range)
    written = []
    if args.report is not None:
        from saved_runs.diagnosis.report import write_diagnosis_report

        written.append(f"report written to {write_diagnosis_report(diagnosis, args.report)}")
    if args.out is not None:
        written.append(f"model written to {write_model(diagnosis, args.out)}")
    if args.json:
        json.dump(diagnosis.to_dict(), sys.stdout, allow_nan=False)
        sys.stdout.write("\n")
        for line in written:
            print(line, file=sys.stderr)
    else:
        diagnosis.print_summary(sys.stdout)
        for line in written:
            print(line)
    return 0


def register(sub) -> None:  # noqa: ANN001
    p = sub.add_parser("diagnose", help="find the physical effect a run's model lacks and show the gap shrink",
                       description="Compare a saved run with a model of physical effects (docs/diagnosis.md): "
                                   "where they disagree, which missing effect explains it (named only on "
                                   "significant evidence), the model with it added, until nothing is left.")
    p.add_argument("run_dir", type=Path)
    p.add_argument("--model", type=Path, default=None,
                   help="model file (TOML; kind and [[effect]] tables); default: an empty model")
    p.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    p.add_argument("--accept-out-of-range", action="store_true",
                   help="use values outside the set-up's validation limits instead of refusing the run (as process)")
    p.add_argument("--report", type=Path, default=None, metavar="FILE",
                   help="write an HTML report with a plot per step")
    p.add_argument("--out", type=Path, default=None, metavar="MODEL_OUT.toml",
                   help="write the final model as a model file")
    p.set_defaults(func=run)
