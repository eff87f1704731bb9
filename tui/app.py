"""The Textual application: a technician-guided measurement session, and a browser for saved runs.

The run itself is :class:`~tui.session.RunSession` (the engine in a worker
thread, the TUI operator, the live monitor); this module routes its messages
to the session and the screens: the set-up, connect and warm-up, capture,
results and runs screens, and the plan's questions as modal dialogs.
"""

from __future__ import annotations

from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any

from textual.app import App
from textual.binding import Binding

from acquisition.messages import Instruct, Prompt

from .messages import (
    DeviationArrived,
    HeightArrived,
    LiveReadingArrived,
    LogLine,
    OperatorQuestion,
    RunDocument,
    RunEnded,
)
from .screens.dialogs import ConfirmScreen, HelpScreen, QuestionScreen, question_screen
from .screens.runs import RunsScreen
from .screens.setup import SetupScreen

# The acquisition stack (numpy, pandas, scipy, pymodbus, the simulation) is imported when a run starts
# or results are opened, not before the first frame (benchmarks/bench_tui_first_frame.py).
if TYPE_CHECKING:
    from acquisition.acquire import SimOptions
    from acquisition.setup.positioning import PositioningSetup
    from acquisition.setup.straightness import StraightnessSetup

    from .screens.run import RunScreen
    from .session import RunPlanInfo, RunSession

QUIT_WAIT_S = 10.0  # after quit was confirmed, the run has this long to close its files


def plan_info(setup: StraightnessSetup | PositioningSetup, points_before: int = 0) -> RunPlanInfo:
    from acquisition.setup.straightness import StraightnessSetup

    from .session import RunPlanInfo

    if isinstance(setup, StraightnessSetup):
        return RunPlanInfo("straightness", len(setup.steps()), setup.stations, "mm", setup.warmup.enabled,
                           setup.block_length_mm, points_before, setup=setup)
    return RunPlanInfo("positioning", len(setup.measured_stops()), 0, setup.unit, points_before=points_before,
                       datum=setup.datum, setup=setup)


class GuidewayApp(App[None]):
    CSS_PATH = "app.tcss"
    TITLE = "guideway"
    ENABLE_COMMAND_PALETTE = False
    # ? opens the help from every screen but where a text field takes it (it is typed there); F1 from everywhere,
    # a dialog and a text field included (priority: ahead of any widget and of a modal screen)
    BINDINGS = [Binding("q", "quit_app", "quit"), Binding("question_mark", "help", "help", key_display="?"),
                Binding("f1", "help", "help", key_display="F1", show=False, priority=True),
                Binding("f2", "setup", "set-up", show=False), Binding("f3", "runs", "runs", show=False)]

    def __init__(self, *, setup_source: dict[str, Any] | None = None, setup_path: Path | None = None,
                 out: Path | None = None, runs_dir: Path = Path("runs"), simulate: bool = False, seed: int = 0,
                 noise: bool = True, faults: str | None = None, start: str = "setup",
                 live_interval_s: float = 0.05, catalog_url: str | None = None) -> None:
        super().__init__()
        self.setup_source = setup_source
        self.setup_path = setup_path
        self.out = out
        self.runs_dir = Path(runs_dir)
        self.catalog_url = catalog_url  # None: GUIDEWAY_CATALOG, if set (docs/fleet.md)
        self.simulate = simulate
        self.sim_args = (seed, noise, faults)
        self.start = start
        self.live_interval_s = live_interval_s
        self.session: RunSession | None = None
        self.quitting = False
        self.started_from: Path | None = None  # the Results a run was started from (an as-left run), else None
        self._question_open = 0  # ticket of the question shown in a dialog

    def on_mount(self) -> None:
        self.install_screen(SetupScreen(self.setup_source, setup_path=self.setup_path, out=self.out,
                                        simulate=self.simulate), name="setup")
        self.install_screen(RunsScreen(self.runs_dir, self.catalog_url), name="runs")
        self.push_screen(self.start)
        self.call_after_refresh(self._preload)

    def _preload(self) -> None:
        """Import the acquisition stack in a thread once the first frame is drawn, while the technician
        reads the form: F5 then finds it loaded (an F5 before it is done waits on Python's import lock,
        no longer than it would without this)."""
        import threading

        def load() -> None:
            import tui.screens.run  # noqa: F401  (the run screens and the session: acquisition, numpy, pandas)

        threading.Thread(target=load, name="preload-acquisition", daemon=True).start()

    # -- navigation ------------------------------------------------------------------------------
    def _switch(self, screen: Any) -> None:
        while len(self.screen_stack) > 2:  # modal dialogs on top of the current screen
            self.pop_screen()
        self.switch_screen(screen)

    def action_setup(self) -> None:
        if self.run_active:
            self.notify("a run is in progress", severity="warning")
            return
        self._switch("setup")

    def action_runs(self) -> None:
        if self.run_active:
            self.notify("a run is in progress", severity="warning")
            return
        self._switch("runs")

    def action_help(self) -> None:
        """?/F1: the keys of the screen on top (a yes/no dialog's too); F1 again closes it.  A plan's question
        lists its own keys, so it gets no help on top."""
        if isinstance(self.screen, HelpScreen):
            self.screen.dismiss(None)
        elif not isinstance(self.screen, QuestionScreen):
            self.push_screen(HelpScreen(self.screen, list(self.BINDINGS)))

    @property
    def sim_options(self) -> SimOptions:
        from acquisition.acquire import SimOptions

        return SimOptions(*self.sim_args)

    def open_results(self, run_dir: Path, note: str = "") -> None:
        from .screens.results import ResultsScreen

        self._switch(ResultsScreen(run_dir, note))

    @property
    def run_active(self) -> bool:
        return self.session is not None and self.session.active

    # -- runs ---------------------------------------------------------------------------------------
    def start_run(self, source: dict[str, Any], out: Path | None, *, simulate: bool,
                  source_name: str = "set-up", sim: SimOptions | None = None, back: Path | None = None) -> None:
        """A new run of the set-up ``source`` into ``out`` (None: ``RUNS/KIND-<UTC time>``); ``sim``: the simulated
        world when ``simulate`` (None: the application's, ``--seed`` ...); ``back``: the run whose Results started
        it (an as-left run), shown again with the reason when the run does not start."""
        from acquisition.setup.files import setup_from_dict

        from .screens.run import ConnectScreen
        from .session import RunSession

        setup = setup_from_dict(source, source_name)
        self.started_from = back
        info = plan_info(setup)
        if out is None:
            out = self.runs_dir / f"{info.kind}-{datetime.now(UTC).strftime('%Y%m%dT%H%M%SZ')}"
        self._begin(RunSession(self.post_message, info, source, out,
                               simulate=(sim or self.sim_options) if simulate else None, source_name=source_name,
                               live_interval_s=self.live_interval_s), ConnectScreen)

    def resume_run(self, run_dir: Path) -> None:
        """Continue an aborted or crashed run after its last point on disk (the capture screen)."""
        from acquisition.live import LiveDeviation, LiveProfile
        from acquisition.setup.stored import resumed_setup
        from saved_runs.store.reader import load_run

        from .screens.run import CaptureScreen
        from .session import RunSession, add_deviation

        try:
            run = load_run(run_dir)
            setup: Any = resumed_setup(run.meta, run_dir)
        except Exception as exc:  # noqa: BLE001 - shown, not raised: the browser stays usable
            self.notify(f"cannot resume {run_dir}: {exc}", severity="error", markup=False)
            return
        simulated = "simulation" in run.meta or self.simulate
        session = RunSession(self.post_message, plan_info(setup, len(run.points)), None, run_dir,
                             simulate=self.sim_options if simulated else None, resume=True,
                             live_interval_s=self.live_interval_s)
        rows = run.points.to_dict("records")
        session.view.rows = list(rows)
        session.view.skipped = len(run.meta.get("skipped") or [])
        if run.kind == "straightness":  # the profile so far, as the live display computes it
            live = LiveProfile(setup.geometry)
            for row in rows:
                live("event", {"data": row})
            session.view.heights.update(live.heights)
        else:  # the deviations so far, as the live display computes them
            deviations = LiveDeviation(setup.axis_type, setup.environment.to_dict(),
                                       lambda row, dev, label: add_deviation(session.view, row, dev, label))
            for row in rows:
                deviations("event", {"data": row})
        self._begin(session, CaptureScreen)

    def _begin(self, session: RunSession, screen: type[RunScreen]) -> None:
        self.session = session
        session.start()
        self._switch(screen(session))

    # -- messages from the run's thread -------------------------------------------------------------
    def on_live_reading_arrived(self, message: LiveReadingArrived) -> None:
        self._apply(message)

    def on_run_document(self, message: RunDocument) -> None:
        self._apply(message)

    def on_height_arrived(self, message: HeightArrived) -> None:
        self._apply(message)

    def on_deviation_arrived(self, message: DeviationArrived) -> None:
        self._apply(message)

    def on_log_line(self, message: LogLine) -> None:
        self._apply(message)

    def on_operator_question(self, message: OperatorQuestion) -> None:
        self._apply(message)
        from .screens.run import CaptureScreen, ConnectScreen

        q = message.question
        if isinstance(q, Prompt):
            self._ask(q, message.ticket)
        elif isinstance(q, Instruct) and q.key in ("station", "target", "start") \
                and isinstance(self.screen, ConnectScreen):
            self._switch(CaptureScreen(self.screen.session))

    def on_run_ended(self, message: RunEnded) -> None:
        self._apply(message)
        if self.quitting:
            self.exit()
            return
        outcome = message.outcome
        if outcome is None:
            note = f"the run did not start: {message.error}"
        elif outcome.exit_status == "success":
            note = ""
        else:
            note = (f"run {outcome.exit_status}: {outcome.reason}; the points are kept and the run can be "
                    f"resumed (c on the Runs screen)")
        if outcome is None and not (message.run_dir / "run.json").exists() and self.started_from is not None:
            # an as-left run started from its as-found run's Results: back there, with the reason
            self.open_results(self.started_from, note)
            return
        if outcome is None and not (message.run_dir / "run.json").exists():
            # nothing on disk (a device that could not be opened): back to the form, where the reason stays
            # in plain words until the next F5 (not a toast that fades and leaves "set-up valid")
            self._switch("setup")
            setup = self.get_screen("setup")
            if isinstance(setup, SetupScreen):
                setup.show_start_error(message.error or "")
            self.log.error(note)
            return
        self.open_results(message.run_dir, note)

    def _apply(self, message: Any) -> None:
        if self.session is None:
            return
        self.session.apply(message)
        if not self.screen_stack:  # shutting down
            return
        screen = self.screen if not isinstance(self.screen, QuestionScreen | HelpScreen | ConfirmScreen) \
            else self.screen_stack[-2] if len(self.screen_stack) > 1 else None
        if screen is not None and hasattr(screen, "refresh_view"):  # a run screen
            screen.refresh_view()
            screen.sync_bindings()

    def _ask(self, prompt: Prompt, ticket: int) -> None:
        session = self.session
        assert session is not None

        def answered(choice: str | None) -> None:
            if choice is not None and session.view.ticket == ticket and session.view.question is prompt:
                session.answer(choice)

        def push() -> None:
            if session.view.ticket == ticket and session.view.question is prompt and self.screen_stack:
                self.push_screen(question_screen(prompt, session.view.fault_attempts or 1, session.view.fault_since),
                                 answered)

        # after the screen switch an instruction may have started (ConnectScreen -> CaptureScreen) is done: a
        # question right after it (Space at once, the block not still yet) pushed on top of the switch made a
        # Header of the screen going away update its title after its children were gone (a NoMatches crash)
        self.call_after_refresh(push)

    # -- quitting -----------------------------------------------------------------------------------
    def action_quit(self) -> None:  # type: ignore[override]
        """Ctrl+Q (Textual's own quit key): the same question as ``q``, never a silent exit."""
        self.action_quit_app()

    def edited_form(self) -> bool:
        """The set-up form holds changes not saved (whichever screen is showing)."""
        try:
            setup = self.get_screen("setup")
        except KeyError:  # not installed yet (before the first frame)
            return False
        return isinstance(setup, SetupScreen) and setup.edited

    def action_quit_app(self) -> None:
        """Every way to quit (q, Ctrl+Q, from any screen) asks first when quitting would lose something: a
        run in progress (aborted, resumable) or a set-up form with changes not saved."""
        if isinstance(self.screen, ConfirmScreen):  # the question is already asked
            return
        if not self.run_active:
            if not self.edited_form():
                self.exit()
                return

            def leave(yes: bool | None) -> None:
                if yes:
                    self.exit()

            self.push_screen(ConfirmScreen("Quit without saving?", "The set-up on the form has changes that are "
                                           "not saved (Ctrl+S on the set-up screen saves them to the set-up "
                                           "file). Quit and lose them?"), leave)
            return

        def answered(yes: bool | None) -> None:
            if yes and self.session is not None:
                self.quitting = True
                self.session.abort()
                self.set_timer(QUIT_WAIT_S, self.exit)

        self.push_screen(ConfirmScreen("Quit?", "A run is in progress. Quitting aborts it: the points captured "
                                       "stay on disk and the run stays resumable (Runs screen, or guideway "
                                       "acquire --resume)."), answered)

    def on_unmount(self) -> None:
        if self.run_active and self.session is not None:  # closed some other way: leave the run resumable
            self.session.abort()
            self.session.join(QUIT_WAIT_S)
