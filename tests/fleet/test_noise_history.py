"""``guideway diagnose RUN --noise-history N``: the serial correlation of the machine's errors estimated
from its earlier runs in the catalogue (SQLite and PostgreSQL), chosen by machine, axis, kind and date."""

from __future__ import annotations

import json
from pathlib import Path

from tests.cli import guideway, one_line_error
from tests.saved_runs.test_diagnose_positioning import TARGETS_MM, linear_cycle, write_run
from tests.saved_runs.test_diagnose_real_data import ar1


def machine_run(root: Path, name: str, machine: str, axis: str, created: str, seed: int, status: str = "complete"
                ) -> Path:
    """A positioning run with AR(1) noise at φ 0.8, its run.json naming machine, axis, creation time, status."""
    rows = linear_cycle(TARGETS_MM, 5)
    run = write_run(root / name, rows, [], seed=seed, noise_um=ar1(len(rows), 0.8, 90_000 + seed))
    meta = json.loads((run / "run.json").read_text())
    meta.update(machine=machine, axis=axis, created=created, status=status, uid=f"uid-{name}")
    (run / "run.json").write_text(json.dumps(meta))
    return run


def test_the_latest_earlier_runs_of_the_machine_and_axis_are_used(tmp_path: Path, catalog_url: str) -> None:
    """Of the catalogue, only complete runs of the same machine, axis and kind created before the run count,
    newest first: here M1/X of March, February and January (not April's, which is later, nor Y's, nor M2's,
    nor the aborted one)."""
    runs = {
        "jan": machine_run(tmp_path, "jan", "M1", "X", "2026-01-10T08:00:00Z", 1),
        "feb": machine_run(tmp_path, "feb", "M1", "X", "2026-02-10T08:00:00Z", 2),
        "mar": machine_run(tmp_path, "mar", "M1", "X", "2026-03-10T08:00:00Z", 3),
        "aborted": machine_run(tmp_path, "aborted", "M1", "X", "2026-03-20T08:00:00Z", 4, status="aborted"),
        "axis_y": machine_run(tmp_path, "axis_y", "M1", "Y", "2026-03-25T08:00:00Z", 5),
        "other": machine_run(tmp_path, "other", "M2", "X", "2026-03-26T08:00:00Z", 6),
        "now": machine_run(tmp_path, "now", "M1", "X", "2026-03-30T08:00:00Z", 7),
        "later": machine_run(tmp_path, "later", "M1", "X", "2026-04-30T08:00:00Z", 8),
    }
    assert guideway("catalog", "add", *map(str, runs.values()), "--catalog", catalog_url)[0] == 0
    code, out, err = guideway("diagnose", str(runs["now"]), "--noise-history", "2", "--catalog", catalog_url, "--json")
    assert code == 0, err
    used = [h["run"] for h in json.loads(out)["rule"]["ar1_history"]]
    assert used == [str(runs["mar"].resolve()), str(runs["feb"].resolve())]
    assert "2 earlier run(s) of machine 'M1', axis 'X'" in err

    code, out, err = guideway("diagnose", str(runs["now"]), "--noise-history", "5", "--catalog", catalog_url)
    assert code == 0, err
    assert "3 earlier run(s) of machine 'M1', axis 'X'" in err and "(asked for 5)" in err
    assert "serial correlation: estimated from this run and 3 earlier run(s) (630 points" in out

    code, out, err = guideway("diagnose", str(runs["jan"]), "--noise-history", "3", "--catalog", catalog_url)
    assert code == 0 and "no earlier complete run of machine 'M1', axis 'X'" in err
    assert "serial correlation" not in out


def test_a_run_without_machine_or_axis_and_bad_counts_are_refused(tmp_path: Path) -> None:
    url = f"sqlite:///{tmp_path / 'catalog.sqlite'}"
    run = machine_run(tmp_path, "anon", "", "X", "2026-03-30T08:00:00Z", 1)
    assert guideway("catalog", "add", str(run), "--catalog", url)[0] == 0
    one_line_error(guideway("diagnose", str(run), "--noise-history", "3", "--catalog", url),
                   "records no machine", "--noise-from")
    one_line_error(guideway("diagnose", str(run), "--noise-history", "0", "--catalog", url), "--noise-history 0")
    one_line_error(guideway("diagnose", str(run), "--noise-history", "2", "--noise-from", str(run)), "not allowed")


def test_the_tui_diagnosis_uses_the_machines_history_and_h_switches_it(tmp_path: Path) -> None:
    """With a catalogue, `d` on the Results screen pools the serial correlation over the machine's earlier
    runs (said under the steps); `h` diagnoses the run alone, and says so."""
    import asyncio

    from tests.tui.sessions import screen_name, widget_text
    from tests.waiting import wait_for_app
    from tui.app import GuidewayApp

    url = f"sqlite:///{tmp_path / 'catalog.sqlite'}"
    runs = [machine_run(tmp_path, name, "M1", "X", f"2026-0{i}-10T08:00:00Z", i)
            for i, name in enumerate(("jan", "feb", "mar", "now"), start=1)]
    assert guideway("catalog", "add", *map(str, runs), "--catalog", url)[0] == 0
    seen: list[tuple[str, dict]] = []

    async def main() -> None:
        app = GuidewayApp(runs_dir=tmp_path, start="runs", catalog_url=url)
        async with app.run_test(size=(80, 24)) as pilot:
            app.open_results(runs[-1])
            await wait_for_app(pilot, lambda: getattr(app.screen, "evaluation", None) is not None,
                               what="the evaluation", timeout_s=60)
            await pilot.press("d")
            await wait_for_app(pilot, lambda: screen_name(app) == "DiagnosisScreen", what="the diagnosis")
            screen = app.screen
            for key in ("", "h"):
                if key:
                    screen.result = None
                    await pilot.press(key)
                await wait_for_app(pilot, lambda: not screen.running and screen.result, what="the diagnosis",
                                   timeout_s=60)
                await pilot.pause()
                seen.append((widget_text(app, "#diag-table"), screen.result))

    asyncio.run(main())
    (pooled, with_history), (alone, without) = seen
    assert [h["run"] for h in with_history["rule"]["ar1_history"]] == [str(r.resolve()) for r in runs[2::-1]]
    assert "serial correlation: from this run and 3 earlier run(s) of the machine (630 points)" in pooled
    assert "noise history: 3 earlier run(s) of machine 'M1', axis 'X'" in pooled
    assert without["rule"]["ar1_history"] == [] and "serial correlation" not in alone
    assert "noise history: off" in alone


def test_runs_dated_in_the_future_are_left_out_of_the_history_and_named(tmp_path: Path) -> None:
    """A rig clock at 2099: its runs are "earlier" than a run also dated 2099 only by the wrong clock; they are
    left out of the noise history (as out of trends) and the note names them."""
    url = f"sqlite:///{tmp_path / 'catalog.sqlite'}"
    runs = {
        "jan": machine_run(tmp_path, "jan", "M1", "X", "2026-01-10T08:00:00Z", 1),
        "ahead": machine_run(tmp_path, "ahead", "M1", "X", "2099-01-01T08:00:00Z", 2),
        "now": machine_run(tmp_path, "now", "M1", "X", "2099-06-01T08:00:00Z", 3),
    }
    assert guideway("catalog", "add", *map(str, runs.values()), "--catalog", url)[0] == 0
    code, out, err = guideway("diagnose", str(runs["now"]), "--noise-history", "3", "--catalog", url, "--json")
    assert code == 0, err
    used = [h["run"] for h in json.loads(out)["rule"]["ar1_history"]]
    assert used == [str(runs["jan"].resolve())]
    assert "1 earlier run(s) of machine 'M1', axis 'X'" in err
    assert "left out 1 run(s) dated in the future (check the rig's clock): ahead (created 2099-01-01T08:00:00Z)" in err
