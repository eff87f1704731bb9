"""``guideway diagnose RUN_DIR --model MODEL.toml [--noise-from RUN ... | --noise-history N [--catalog URL]]
[--json] [--report FILE] [--out MODEL_OUT.toml]``: find the physical effect the model lacks, add it and show
the gap shrink."""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

from .catalog import add_catalog_option
from .process import warn_about_run


def earlier_runs(args: argparse.Namespace) -> list[Path]:
    """The runs whose errors' serial correlation is pooled with the run's: ``--noise-from``, or the
    ``--noise-history`` latest earlier runs of the machine and axis in the catalogue (said on stderr)."""
    if args.noise_history is None:
        return list(args.noise_from)
    from fleet.catalog.database import open_catalog
    from fleet.catalog.history import earlier_runs as catalogued

    with open_catalog(args.catalog, create=False) as cat:
        history = catalogued(cat, args.run_dir, args.noise_history)
    print(f"noise history: {history.note}", file=sys.stderr)
    return list(history.runs)


def run(args: argparse.Namespace) -> int:
    # The fits are small (at most n x ~110): a BLAS thread pool only contends with itself and other
    # processes (benchmarks/bench_diagnose.py); one thread unless the user says otherwise.  Set before
    # numpy is first imported by this command.
    for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(var, "1")
    from saved_runs.diagnosis.diagnose import diagnose_run, write_model
    from saved_runs.store.reader import load_run

    from .progress import progress_display, short

    warn_about_run(load_run(args.run_dir), "diagnosing the")
    noise_from = earlier_runs(args)
    written = []
    with progress_display(json_output=args.json) as stages:
        what = f"{len(noise_from)} earlier run(s), then each channel" if noise_from else "each channel"
        steps = stages.stage(f"diagnosing {short(args.run_dir)} ({what})")
        diagnosis = diagnose_run(args.run_dir, args.model, accept_out_of_range=args.accept_out_of_range,
                                 noise_from=noise_from, progress=steps)
        if args.report is not None:
            from saved_runs.diagnosis.report import write_diagnosis_report

            stages.stage(f"writing {short(args.report)}")
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
    history = p.add_mutually_exclusive_group()
    history.add_argument("--noise-from", nargs="+", type=Path, default=[], metavar="RUN",
                         help="earlier runs of the same machine and axis: the serial correlation of the errors is "
                              "estimated from them with this run (docs/diagnosis.md, 'φ from the machine's "
                              "earlier runs')")
    history.add_argument("--noise-history", type=int, default=None, metavar="N",
                         help="as --noise-from, with the N latest earlier runs of the run's machine and axis in "
                              "the catalogue")
    add_catalog_option(p)
    p.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    p.add_argument("--accept-out-of-range", action="store_true",
                   help="use values outside the set-up's validation limits instead of refusing the run (as process)")
    p.add_argument("--report", type=Path, default=None, metavar="FILE",
                   help="write an HTML report with a plot per step")
    p.add_argument("--out", type=Path, default=None, metavar="MODEL_OUT.toml",
                   help="write the final model as a model file")
    p.set_defaults(func=run)
