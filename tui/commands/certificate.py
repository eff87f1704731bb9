"""``guideway certificate RUN --out FILE.pdf``: a calibration certificate (PDF) of a saved run
(docs/certificate.md)."""

from __future__ import annotations

import argparse
from pathlib import Path

from .process import add_evaluator_options, evaluator_options


def run(args: argparse.Namespace) -> int:
    from saved_runs.certificate.build import CertificateOptions, build_certificate, parse_issue_date

    evaluation = evaluator_options(args)
    rule = str(evaluation.pop("decision_rule", "simple"))
    options = CertificateOptions(
        number=args.number, decision_rule=rule, lab=args.lab, customer=args.customer, as_left=args.as_left,
        issue_date=parse_issue_date(args.issue_date) if args.issue_date else None, evaluation=evaluation)
    path = build_certificate(args.run_dir, args.out, options)
    print(f"certificate written to {path}")
    return 0


def register(sub) -> None:  # noqa: ANN001
    p = sub.add_parser("certificate", help="write a calibration certificate (PDF) of a saved run",
                       description="Evaluate a complete saved run and write its calibration certificate (ISO/IEC "
                                   "17025 7.8): laboratory, customer, item, method, instruments and traceability, "
                                   "environment, results with U and k, as found / as left, statement of conformity. "
                                   "The same run and options give the same bytes. See docs/certificate.md.")
    p.add_argument("run_dir", type=Path, help="the (as-found) run")
    p.add_argument("--out", type=Path, required=True, help="PDF file to write")
    p.add_argument("--as-left", type=Path, default=None, metavar="RUN",
                   help="the run measured after adjustment / compensation: both side by side with the delta")
    p.add_argument("--number", default=None, metavar="N",
                   help="certificate number (default GW- and the first 10 hex digits of the run's SHA-256)")
    p.add_argument("--issue-date", default=None, metavar="YYYY-MM-DD",
                   help="date of issue (default: the last date of measurement)")
    p.add_argument("--lab", type=Path, default=None, metavar="LAB.toml",
                   help="the laboratory: name, address, accreditation, place, authoriser, authoriser_role")
    p.add_argument("--customer", type=Path, default=None, metavar="CUSTOMER.toml",
                   help="the customer: name, address, reference, and [item] serial, model, controller, condition")
    add_evaluator_options(p)  # --decision-rule, --method, --mc-trials, --k, --edition as process takes them
    p.set_defaults(func=run)
