"""``guideway process RUN_DIR``: evaluate a saved run and write its results."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any


def run(args: argparse.Namespace) -> int:
    from saved_runs.evaluation.evaluate import evaluate_run
    from saved_runs.store.reader import load_run

    from .progress import progress_display, short

    options = evaluator_options(args)
    with progress_display(json_output=args.json) as stages:  # saved_runs' process_run_dir, in stages
        stages.stage(f"reading {short(args.run_dir)}")
        run_ = load_run(args.run_dir)
        mc = " (Monte Carlo trials)" if run_.kind == "straightness" else ""  # the long part; positioning: none
        result = evaluate_run(run_, progress=stages.stage(f"evaluating {short(args.run_dir)}{mc}"), **options)
        warn_about_run(run_, "processing the")
        if not args.no_write:
            stages.stage("writing results")
            result.write(run_.path / "results", plot=args.plot)
    if args.json:
        json.dump(result.to_dict(), sys.stdout, allow_nan=False)
        sys.stdout.write("\n")
    else:
        result.print_summary(sys.stdout)
        if not args.no_write:
            print(f"results written to {run_.path / 'results'}")
    return 0


def warn_about_run(run_: Any, doing: str) -> None:
    """The run's read warnings, a live compensation that stopped during the run and, for an unfinished run,
    that only its recorded points are used (``doing``: e.g. "processing the")."""
    from saved_runs.store.compensation import live_compensation_stopped

    for w in run_.warnings:
        print(f"guideway: warning: {w}", file=sys.stderr)
    if stopped := live_compensation_stopped(run_.meta):
        print(f"guideway: warning: {run_.path}: {stopped}", file=sys.stderr)
    if run_.meta.get("status") != "complete":
        print(f"guideway: warning: run status is {run_.meta.get('status')!r}; {doing} "
              f"{run_.n_points} point(s) recorded", file=sys.stderr)


def evaluator_options(args: argparse.Namespace) -> dict[str, object]:
    """Evaluator options given on the command line (only those set; one the run's kind does not
    take is refused by saved_runs.evaluation.evaluate.evaluate_run)."""
    opts: dict[str, object] = {}
    if args.method is not None:
        opts["method"] = args.method
    if getattr(args, "k", None) is not None:
        if not args.k > 0:
            from saved_runs.errors import UserError

            raise UserError(f"--k must be a positive coverage factor, got {args.k}")
        opts["k"] = args.k
    if getattr(args, "edition", None) is not None:
        opts["edition"] = args.edition
    if getattr(args, "decision_rule", None) is not None:
        opts["decision_rule"] = args.decision_rule
    if getattr(args, "accept_out_of_range", False):
        opts["accept_out_of_range"] = True
    if args.mc_trials is not None:
        if args.mc_trials < 0 or args.mc_trials == 1:
            from saved_runs.errors import UserError

            raise UserError(f"--mc-trials must be 0 (off) or at least 2, got {args.mc_trials}")
        opts["mc_trials"] = args.mc_trials
    return opts


def add_evaluator_options(parser: argparse.ArgumentParser) -> None:
    """The evaluation options shared by ``process`` and ``report``."""
    from saved_runs.evaluation.options import DECISION_RULES, EDITIONS, METHODS

    parser.add_argument("--method", choices=METHODS, default=None,
                        help="straightness decoupling method (default: exact; see docs/conventions.md)")
    parser.add_argument("--mc-trials", type=int, default=None, metavar="N",
                        help="Monte Carlo trials for the straightness uncertainty (default 10000, fewer "
                             "above 200 stations: trials x stations <= 2e6, at least 1000; 0 = off)")
    parser.add_argument("--k", type=float, default=None,
                        help="ISO 230-2 coverage factor for a positioning run (default 2)")
    parser.add_argument("--edition", choices=EDITIONS, default=None,
                        help="ISO 230-2 edition recorded for a positioning run (default ISO 230-2:2014)")
    parser.add_argument("--decision-rule", choices=DECISION_RULES, default=None,
                        help="how a value is decided against the set-up's [tolerance]: simple (ILAC-G8 simple "
                             "acceptance, default), guard-band (w = U) or iso14253 (conforms / does not conform / "
                             "not decidable); docs/certificate.md")
    parser.add_argument("--accept-out-of-range", action="store_true",
                        help="evaluate values outside the set-up's validation limits instead of refusing the "
                             "run (they are listed in the results and marked in the report)")


def register(sub) -> None:  # noqa: ANN001
    pr = sub.add_parser("process", help="evaluate a saved run and write its results")
    pr.add_argument("run_dir", type=Path)
    pr.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    pr.add_argument("--no-write", action="store_true", help="do not write results/")
    pr.add_argument("--plot", action="store_true",
                    help="also draw results/profile.png (positioning.png); `guideway report` draws its own")
    add_evaluator_options(pr)
    pr.set_defaults(func=run)
