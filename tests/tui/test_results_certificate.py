"""The Results screen's certificate key (p): results/certificate.pdf, the same bytes as ``guideway certificate``
with the default options; a run the certificate refuses gives a notice, no file."""

from __future__ import annotations

import asyncio
from pathlib import Path
from typing import Any

from tests.cli import guideway
from tests.tui.test_results_screen import copy_run
from tests.waiting import wait_for_app
from tui.app import GuidewayApp


def press_p(run: Path) -> list[str]:
    """Open the results of ``run``, press p, wait for the file or a notice; the notices shown."""
    out: list[list[str]] = []

    async def main() -> None:
        app = GuidewayApp(runs_dir=run.parent, start="runs")
        async with app.run_test(size=(80, 24)) as pilot:
            app.open_results(run)
            await wait_for_app(pilot, lambda: getattr(app.screen, "evaluation", None) is not None
                               or bool(app._notifications), what="the evaluation", timeout_s=60)
            await pilot.press("p")
            await wait_for_app(pilot, lambda: len(app.screen.written) == 1 or any(
                n.severity == "error" for n in app._notifications), what="the certificate", timeout_s=60)
            out.append([n.message for n in app._notifications if n.severity == "error"])

    asyncio.run(main())
    return out[0]


def test_p_writes_the_certificate_the_command_writes(tmp_path: Path) -> None:
    run = copy_run(tmp_path, "positioning-x")
    assert press_p(run) == []
    cli = tmp_path / "cli.pdf"
    assert guideway("certificate", run, "--out", cli).returncode == 0
    assert (run / "results" / "certificate.pdf").read_bytes() == cli.read_bytes()


def test_a_refused_certificate_is_a_notice(tmp_path: Path) -> None:
    run = copy_run(tmp_path, "straightness-aborted")
    notices: Any = press_p(run)
    assert any("cannot issue a certificate" in n for n in notices), notices
    assert not (run / "results" / "certificate.pdf").exists()
