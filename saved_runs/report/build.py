"""``build_report``: the printable, self-contained HTML report of a saved run.

Sections by run kind (straightness or positioning) between the shared run identity,
status, instruments, environment and conventions sections; a footer names the tool
version and the command that produced the page."""

from __future__ import annotations

import shlex
from datetime import UTC, datetime
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import Any

from ..errors import RunFormatError
from ..evaluation.evaluate import evaluate_run
from ..store.format import run_axis
from ..store.reader import LoadedRun, load_run
from .common import (
    conventions_section,
    environment_section,
    instruments_section,
    out_of_range_section,
    run_section,
    simulated_banner,
    status_section,
)
from .html import HtmlPage, write_page


def tool_version() -> str:
    try:
        return version("guideway")
    except PackageNotFoundError:  # running from a source tree that is not installed
        return "unknown"


def report_command(run_dir: Path | str, out: Path | str | None, options: dict[str, Any]) -> str:
    """The ``guideway report`` command line that reproduces the report."""
    args = ["guideway", "report", str(run_dir)]
    if out is not None:
        args += ["--out", str(out)]
    for key, value in options.items():
        if value is True:  # a flag
            args.append(f"--{key.replace('_', '-')}")
        elif value is not False:
            args += [f"--{key.replace('_', '-')}", str(value)]
    return shlex.join(args)


def evaluate_for_report(run: LoadedRun, options: dict[str, Any]) -> tuple[Any, str | None]:
    """(evaluation, None), or (None, why) for an unfinished run that cannot be evaluated.

    A complete run that cannot be evaluated is an error (RunFormatError), as in ``process``."""
    try:
        return evaluate_run(run, **options), None
    except RunFormatError as exc:
        if run.meta.get("status") == "complete":
            raise
        return None, str(exc)


def render_report(run: LoadedRun, evaluation: Any, *, not_evaluated: str | None = None,
                  command: str = "") -> str:
    """The HTML document of ``run`` and its ``evaluation`` (None: ``not_evaluated`` says why)."""
    from ..evaluation.positioning import PositioningEvaluation
    from ..evaluation.straightness import StraightnessEvaluation
    from .positioning import positioning_headline, positioning_sections
    from .straightness import straightness_headline, straightness_sections

    m = run.meta
    axis = run_axis(m)
    title = f"guideway {run.kind} report — {m.get('machine') or 'machine'}" + (f", axis {axis}" if axis else "")
    page = HtmlPage(title)
    simulated_banner(page, run)
    status_section(page, run)
    out_of_range_section(page, evaluation)
    if isinstance(evaluation, StraightnessEvaluation):
        straightness_headline(page, evaluation)
    elif isinstance(evaluation, PositioningEvaluation):
        positioning_headline(page, evaluation)
    run_section(page, run)
    if isinstance(evaluation, StraightnessEvaluation):
        straightness_sections(page, evaluation)
    elif isinstance(evaluation, PositioningEvaluation):
        positioning_sections(page, evaluation)
    else:
        page.heading("Results")
        page.alert(f"Not evaluated: {not_evaluated or 'no evaluator for this run kind'}")
    instruments_section(page, run)
    environment_section(page, run)
    conventions_section(page, run.kind)
    generated = datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%SZ")
    page.paragraph(f"Produced by guideway {tool_version()} on {generated} with: {command}", "note footer")
    return page.render()


def build_report(run_dir: Path | str, *, out: Path | str | None = None, **options: Any) -> Path:
    """Evaluate ``run_dir`` and write its HTML report; return the file written.

    ``out`` defaults to ``RUN_DIR/results/report.html``.  ``options`` go to the
    evaluator (saved_runs.evaluation.evaluate.EVALUATOR_OPTIONS); only those given are used."""
    run = load_run(run_dir)
    options = {k: v for k, v in options.items() if v is not None}
    evaluation, why = evaluate_for_report(run, options)
    html = render_report(run, evaluation, not_evaluated=why, command=report_command(run_dir, out, options))
    path = Path(out) if out is not None else run.path / "results" / "report.html"
    return write_page(path, html, option="--out", example="report.html")
