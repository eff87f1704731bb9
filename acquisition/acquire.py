"""``guideway acquire straightness``: one run from set-up to run directory.

Opens the devices (real endpoints from the set-up, or simulated ones on real
transports with ``simulate``), picks the operator (plain terminal, or the
automatic simulated technician), and runs the straightness plan with the run
store subscribed.  ``auto`` with real devices is hands-free capture: the plan
waits at each station until the interferometer shows the block there and
still (set-up ``[auto]``), then captures.  ``resume`` continues an interrupted run in the same
directory after its last completed step.  ``guideway demo`` is a thin call
into :func:`run_straightness`.
"""

from __future__ import annotations

import contextlib
import functools
import sys
import tempfile
from collections.abc import Callable, Iterator
from contextlib import AbstractContextManager, ExitStack
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, TextIO

from drivers.errors import DeviceError, ProtocolError, TransportTimeout
from drivers.modbus_link import parse_modbus_url
from saved_runs.errors import SetupError, UserError
from saved_runs.store.lock import run_writer_lock
from saved_runs.store.writer import RunStore

from . import inposition  # noqa: F401 - registers the in-position message handlers
from .cataloguing import add_completed_run, setup_catalog_url, storable_setup_source
from .compensation import NO_COMPENSATION, ActiveCompensation, load_compensation
from .engine import RunEngine, RunOutcome, Subscriber
from .live import DeviationCallback, HeightCallback, LiveDeviation, LiveProfile
from .messages import Log, Prompt
from .operators import AutoOperator, Operator, TerminalOperator
from .plans.positioning import ARROW, positioning_plan, positioning_resume_point
from .plans.straightness import ResumePoint, resume_point, straightness_plan
from .rig import Rig, open_controller_rig, open_rig
from .setup.positioning import PositioningSetup, positioning_setup_from_dict
from .setup.stored import resumed_setup
from .setup.straightness import StraightnessSetup, straightness_setup_from_dict
from .simulated.faults import fault_report, refuse_faults_that_cannot_fire
from .simulated.machine import SimulatedMachine, start_simulated_machine
from .simulated.rig import SimulatedRig, SimulatedTransmitter, start_simulated_rig, start_simulated_transmitter
from .simulated.scenario import Scenario, load_scenario
from .simulated.sensors import REQUESTS_PER_SAMPLE, sensor_emulator


def _device_id(url: str) -> int:
    """The Modbus device id a set-up's controller URL names (1 when it names none); the simulated
    controller answers there, like the real one behind its gateway."""
    if not url:
        return 1
    try:
        device_id = parse_modbus_url(url).device_id
    except ValueError as exc:
        raise SetupError(f"[controller] url: {exc}") from None
    return 1 if device_id is None else device_id


def _simulated_transmitter(url: str, environment: Any, stream: TextIO,
                           cleanup: ExitStack) -> SimulatedTransmitter | None:
    """A simulated XY-MD02 when the set-up names a transmitter, reading the simulation's environment;
    closed with ``cleanup``."""
    if not url:
        return None
    transmitter = start_simulated_transmitter(environment)
    cleanup.callback(transmitter.close)
    print(f"simulated transmitter: XY-MD02 on {transmitter.url} (the set-up names {url})", file=stream)
    return transmitter


@contextlib.contextmanager
def _closed_on_error(cleanup: ExitStack) -> Iterator[None]:
    """Close what ``cleanup`` holds if starting the simulation fails half way."""
    try:
        yield
    except BaseException:
        cleanup.close()
        raise


def _record_devices(store: RunStore, rig: Any, simulate: SimOptions | None, *, resumed: bool) -> None:
    """run.json ``instruments`` (and ``simulation``) of a new run; a resumed run keeps its own."""
    if resumed:
        return
    store.header["instruments"] = rig.instruments()
    if simulate is not None:
        store.header["simulation"] = simulate.to_dict()


def _report_faults(store: RunStore, plan: Any, stream: TextIO) -> None:
    """run.json ``fault_plan`` and a note for every injected fault that did not fire."""
    report = fault_report(plan)
    if report is None:
        return
    store("annotate", {"key": "fault_plan", "value": report})
    asked = ", ".join(f"{d} {n}" for d, n in report["requests"].items())
    for spec in report["not_fired"]:
        print(f"note: fault {spec} did not fire (requests: {asked})", file=stream)


def _print_outcome(outcome: RunOutcome, store: RunStore, out: Path, stream: TextIO) -> None:
    print(f"run {outcome.exit_status}: {store.points_written} points in {out}"
          + (f" ({outcome.reason})" if outcome.reason else ""), file=stream)


EngineHook = Callable[[RunEngine], AbstractContextManager[Any]]
"""Called with the engine (its rig open) before the run starts; the context it returns is held for the
run and left before the devices close (the TUI: live readings, pause/abort from the UI thread)."""


def _engine_context(hook: EngineHook | None, engine: RunEngine) -> AbstractContextManager[Any]:
    return hook(engine) if hook is not None else contextlib.nullcontext()


@dataclass(frozen=True)
class SimOptions:
    """A simulated rig: world seed, instrument noise on/off, injected faults (mocks/faults.py), and the
    scenario file whose effects the simulated devices apply (acquisition/simulated/scenario.py; None: the set-up's
    ``[simulation] scenario``, if any)."""

    seed: int = 0
    noise: bool = True
    faults: str | None = None
    wire_time: bool = True  # False: zero-latency emulators (benchmarks)
    scenario: str | None = None

    def to_dict(self) -> dict[str, Any]:
        return {"seed": self.seed, "noise": self.noise, **({"scenario": self.scenario} if self.scenario else {})}

    def resumed(self, stored: dict[str, Any]) -> SimOptions:
        """The options of a resumed run: the seed, noise and scenario it started with (run.json ``simulation``)."""
        return replace(self, seed=int(stored["seed"]), noise=bool(stored["noise"]),
                       scenario=stored.get("scenario") or None)


def _scenario(simulate: SimOptions | None, setup_scenario: str, kind: str) -> tuple[SimOptions | None, Scenario | None]:
    """The scenario of a simulated run (``--scenario`` before the set-up's), recorded in the options."""
    path = (simulate.scenario or setup_scenario) if simulate is not None else None
    if simulate is None or not path:
        return simulate, None
    scenario = load_scenario(path)
    if scenario.kind != kind:
        raise SetupError(f"{path} is a {scenario.kind} scenario; this is a {kind} run")
    return replace(simulate, scenario=str(path)), scenario


@dataclass(frozen=True)
class AcquireResult:
    run_dir: Path
    outcome: RunOutcome
    setup: StraightnessSetup
    sim: SimulatedRig | None  # stopped; its world stays readable (ground truth for tests)
    faults: tuple[str, ...] = ()  # device faults met during the run (recovered or not)
    live: LiveProfile | None = None  # the heights computed while the run went on


def _operator(given: Operator | None, actions: dict[str, Any], auto: bool, stdin: TextIO, stream: TextIO
              ) -> Operator:
    """The operator of a run; a given one (tests, the TUI) also gets the simulated physical actions."""
    if given is None:
        return AutoOperator(actions, log_to=stream) if auto else TerminalOperator(stdin, stream, actions)
    own = getattr(given, "actions", None)
    if isinstance(own, dict):
        given.actions = {**actions, **own}  # type: ignore[attr-defined]
    return given


def _open_store(setup: StraightnessSetup | None, out: Path, resume: bool
                ) -> tuple[RunStore, StraightnessSetup, ResumePoint | None]:
    if not resume:
        if setup is None:
            raise SetupError("a new run needs --setup SETUP.toml")
        store = RunStore(out, setup.header())
        store.prepare()
        return store, setup, None
    store = RunStore.for_resume(out)
    if store.meta.get("kind") != "straightness":
        raise UserError(f"{out}: a {store.meta.get('kind')} run; resume it with guideway acquire "
                        f"{store.meta.get('kind')}")
    stored = resumed_setup(store.meta, out, setup)
    assert isinstance(stored, StraightnessSetup)
    rp = resume_point(store.meta, store.loaded_points, stored.steps())
    return store, stored, rp


# A device that answered its first request with an error, a damaged reply or not in time: a one-off fault
# like any later one (an unreachable address, a refused connection, is not: it is reported at once).
ONE_OFF_FAULTS = (DeviceError, ProtocolError, TransportTimeout)


def _open_devices(open_fn: Callable[[], Rig], operator: Operator, store: RunStore) -> tuple[Rig, list[str]]:
    """Open the devices.  A one-off fault on the very first request pauses the run as the engine pauses it
    for a later one: the operator retries (the devices are opened again) or aborts (the fault is raised).
    Returns the rig and the faults met, which run.json ``faults`` lists with the later ones."""
    faults: list[str] = []
    while True:
        try:
            rig = open_fn()
        except UserError as exc:
            if not isinstance(exc.__cause__, ONE_OFF_FAULTS):
                raise
            fault = str(exc)
            faults.append(fault)
            operator.log(Log(f"device fault: {fault}"))
            answer = operator.prompt(Prompt(
                f"Device fault: {fault}. Check the device, its cable and power, then retry (the tool "
                "reconnects), or abort the run.", ("retry", "abort"), key="fault", fault=fault))
            if answer != "retry":
                raise
            continue
        if faults:
            operator.log(Log("devices reconnected; going on"))
            prior = list(store.meta.get("faults", [])) if store.meta else []
            if store.meta:  # a resumed run: its earlier faults, then these
                store.meta["faults"] = prior + faults
            else:
                store.header["faults"] = faults
        return rig, faults


def _one_writer(run: Callable[..., Any]) -> Callable[..., Any]:
    """The run directory's writer lock (saved_runs/store/lock.py) held for the whole run, new or
    resumed: a second writer is refused at once, naming this process.  A run that fails before its
    first record (devices unreachable, bad set-up) leaves no empty run directory behind; one that
    started keeps everything it wrote."""

    @functools.wraps(run)
    def wrapper(setup: Any, out: Path | str, *args: Any, resume: bool = False, **kwargs: Any) -> Any:
        existed = Path(out).exists()
        try:
            with run_writer_lock(out, new=not resume):
                return run(setup, out, *args, resume=resume, **kwargs)
        except BaseException:
            if not existed:
                with contextlib.suppress(OSError):  # rmdir refuses a directory that holds anything
                    Path(out).rmdir()
            raise

    return wrapper


def _sensor_requests(sim: SimulatedRig, setup: StraightnessSetup, rp: ResumePoint | None, auto: bool) -> int | None:
    """The sensor requests of the rest of a fault-free automatic run (the requests so far, at open,
    plus one averaged reading per remaining step); None when an operator or a warm-up makes it
    open-ended."""
    per_sample = REQUESTS_PER_SAMPLE.get(sim.sensor_protocol)
    if not auto or per_sample is None or sim.faults is None or (setup.warmup.enabled and rp is None):
        return None
    remaining = len(setup.steps()) - (rp.next_index if rp is not None else 0)
    return sim.faults.requests("sensor") + per_sample * setup.samples_per_reading * remaining


@_one_writer
def run_straightness(
    setup: StraightnessSetup | None,
    out: Path | str,
    *,
    simulate: SimOptions | None = None,
    auto: bool = False,
    resume: bool = False,
    stream: TextIO = sys.stdout,
    stdin: TextIO = sys.stdin,
    operator: Operator | None = None,
    hands_free: bool | None = None,
    subscribers: tuple[Subscriber, ...] = (),
    on_engine: EngineHook | None = None,
    on_height: HeightCallback | None = None,
) -> AcquireResult:
    """Acquire (or resume) a straightness run into ``out``; progress goes to ``stream``.

    ``operator`` overrides the operator chosen by ``auto`` (tests and the TUI); ``subscribers`` get the
    engine's documents after the run store; ``on_engine``: see :data:`EngineHook`; ``on_height`` gets
    every live surface height (pass, station, um) as well.  ``hands_free`` (default: ``auto`` with real
    devices): wait at each station for the block instead of asking.
    """
    out = Path(out)
    store, setup, rp = _open_store(setup, out, resume)
    if simulate is not None and resume and "simulation" in store.meta:
        simulate = simulate.resumed(store.meta["simulation"])  # the same simulated world the run started with
    simulate, scenario = _scenario(simulate, setup.scenario, "straightness")
    sim = None
    cleanup = ExitStack()  # simulated devices and their link directory, closed when the run ends
    if simulate is not None:
        with _closed_on_error(cleanup):
            # the sensor is opened through a stable symlink (like a udev name), so a ``close`` fault that
            # re-creates the pty is reconnected by re-opening the same name; removed when the run ends
            link_dir = cleanup.enter_context(tempfile.TemporaryDirectory(prefix="guideway-sim-"))
            # the family the set-up names, at the set-up's line rate if it gives one, else the family's own
            sim = start_simulated_rig(seed=simulate.seed, noise=simulate.noise, faults=simulate.faults,
                                      sensor=setup.devices.sensor_protocol, baudrate=setup.devices.sensor_baud,
                                      block_length_mm=setup.block_length_mm, geometry=setup.geometry,
                                      wire_time=simulate.wire_time, sensor_link=Path(link_dir) / "sensor",
                                      scenario=scenario, device_id=_device_id(setup.devices.controller_url))
            cleanup.callback(sim.close)
            transmitter = _simulated_transmitter(setup.devices.environment_url, sim.world, stream, cleanup)
        devices = replace(setup.devices, sensor_protocol=sim.sensor_protocol, sensor_url=sim.sensor_url,
                          sensor_baud=sim.sensor_baudrate, controller_url=sim.controller_url,
                          environment_url=transmitter.url if transmitter is not None else "")
        print(f"simulated sensor     : {sim.sensor_protocol} on {sim.sensor_url} (pty {sim.sensor_path()})",
              file=stream)
        own_sign = sensor_emulator(sim.sensor_protocol).sensor_sign
        if sim.sensor_sign != own_sign:
            print(f"note: a {sim.sensor_protocol} gives {own_sign}-type values; simulated with sensor_sign "
                  f"{sim.sensor_sign!r} as the set-up says", file=stream)
        print(f"simulated controller : {sim.controller_url}", file=stream)
    else:
        devices = setup.devices
        if not devices.sensor_url:
            raise SetupError("[sensor] port is missing in the setup; give the sensor's serial port or use --simulate")
        if not devices.controller_url:
            raise SetupError("[controller] url is missing in the setup; give the controller's address "
                             "or use --simulate")
    if hands_free is None:
        hands_free = auto and simulate is None
    if hands_free:
        a = setup.auto
        print(f"hands-free: at each station the tool waits up to {a.station_timeout_s:g} s for the block to rest "
              f"at the station (|lin| <= {setup.validation.max_lin_um:g} um, still within {a.still_um:g} um for "
              f"{a.still_s:g} s), then captures", file=stream)
    unattended = auto and operator is None  # the simulated technician, not a given operator
    try:
        actions = {"place_block": sim.place_block} if sim is not None else {}
        operator = _operator(operator, actions, auto, stdin, stream)
        rig, open_faults = _open_devices(
            lambda: open_rig(devices.sensor_protocol, devices.sensor_url, devices.controller_url,
                             baudrate=devices.sensor_baud, word_order=devices.word_order,
                             environment_url=devices.environment_url or None, timing=devices.timing,
                             sensor_options=devices.sensor_options), operator, store)
        try:
            _record_devices(store, rig, simulate, resumed=rp is not None)
            if sim is not None:
                expected = _sensor_requests(sim, setup, rp, unattended)
                refuse_faults_that_cannot_fire(sim.faults, sensor=True, sensor_requests=expected)

            def show(p: int, k: int, h: float) -> None:
                print(f"  live: station {k}{' (return)' if p else ''} surface height {h:+.3f} um", file=stream)
                if on_height is not None:
                    on_height(p, k, h)

            loaded = store.loaded_points if rp is not None else []
            first = loaded[0] if loaded else None
            first_step = next((r for r in loaded if int(r.get("pass", 0)) == 0
                               and int(r["station"]) == int(loaded[0]["station"]) + 1), None)
            live = LiveProfile(setup.geometry, show, first, first_step)
            engine = RunEngine(rig, operator, (store, live, *subscribers))
            engine.faults_at_open = open_faults  # later faults are listed after them
            with _engine_context(on_engine, engine):
                outcome = engine.run(straightness_plan(setup, {}, resume=rp, hands_free=hands_free))
            if sim is not None:
                _report_faults(store, sim.faults, stream)
        finally:
            rig.close()
    finally:
        cleanup.close()
    _print_outcome(outcome, store, out, stream)
    return AcquireResult(out, outcome, setup, sim, tuple(engine.faults), live)


@dataclass(frozen=True)
class PositioningResult:
    run_dir: Path
    outcome: RunOutcome
    setup: PositioningSetup
    sim: SimulatedMachine | None  # stopped; its axis stays readable (ground truth for tests)
    faults: tuple[str, ...] = ()
    live: LiveDeviation | None = None  # the compensated deviations shown while the run went on
    live_stopped: str = ""  # why the run was stopped when its live compensation stopped ("" otherwise)


def live_deviation_printer(stream: TextIO, unit: str) -> DeviationCallback:
    """The terminal line of each new positioning point (values from :class:`LiveDeviation`)."""
    shown = {"um": "µm"}.get(unit, unit)

    def show(row: dict[str, Any], deviation: float, label: str) -> None:
        print(f"  live: run {int(row['run'])} {ARROW[int(row['direction'])]} target {int(row['target_index'])}: "
              f"deviation {deviation:+.3f} {shown} ({label})", file=stream)

    return show


def _check_hands_free(setup: PositioningSetup, auto: bool, simulate: SimOptions | None,
                      operator: Operator | None) -> None:
    """``--auto`` with real devices runs hands-free: not with a manual trigger (M00 at every target)."""
    if auto and simulate is None and operator is None and setup.trigger.mode == "manual":
        raise SetupError('--auto with [trigger] mode = "manual" needs someone to press Cycle Start at every '
                         'target; use mode "in-position" or "stability" for a hands-free run, or leave out --auto')


@_one_writer
def run_positioning(
    setup: PositioningSetup | None,
    out: Path | str,
    *,
    simulate: SimOptions | None = None,
    auto: bool = False,
    resume: bool = False,
    setup_source: dict[str, Any] | None = None,
    stream: TextIO = sys.stdout,
    stdin: TextIO = sys.stdin,
    operator: Operator | None = None,
    subscribers: tuple[Subscriber, ...] = (),
    on_engine: EngineHook | None = None,
    on_deviation: DeviationCallback | None = None,
    live_compensation: Path | str | None = None,
    live_model: str | None = None,
) -> PositioningResult:
    """Acquire (or resume) an ISO 230-2 positioning run into ``out``.

    ``setup_source`` is the set-up file's TOML structure, kept in run.json so a resume rebuilds
    exactly the same set-up (targets included).  ``operator``, ``subscribers``, ``on_engine``: as for
    :func:`run_straightness`; ``on_deviation`` gets every point's live deviation as well (the
    environment-compensated value the terminal shows, :class:`~acquisition.live.LiveDeviation`).
    ``live_compensation``: an as-found run; with ``simulate`` the simulated controller serves the
    live-compensation interface and a compensator (``live_model`` of that run) runs against it over
    loopback Modbus TCP in this process (docs/compensation.md, "Live compensation in simulation").
    """
    out = Path(out)
    predictor = _live_predictor(live_compensation, live_model or "spline", setup, simulate, resume)
    rp = None
    if resume:
        store = RunStore.for_resume(out)
        if store.meta.get("kind") != "positioning":
            raise UserError(f"{out}: a {store.meta.get('kind')} run; resume it with guideway acquire "
                            f"{store.meta.get('kind')}")
        setup = resumed_setup(store.meta, out, setup)
        assert isinstance(setup, PositioningSetup)
        _check_hands_free(setup, auto, simulate, operator)
        rp = positioning_resume_point(store.meta, store.loaded_points, setup.measured_stops())
        active = _compensation(setup, simulate, store.meta)
    else:
        if setup is None:
            raise SetupError("a new run needs --setup SETUP.toml")
        _check_hands_free(setup, auto, simulate, operator)
        active = _compensation(setup, simulate, None)
        record = active.record(setup.unit, _applied_by(simulate)) if active is not None else NO_COMPENSATION
        if predictor is not None:
            if active is not None:
                raise SetupError("--live-compensation with a compensation table: choose one")
            record = _live_record(predictor)
        stored = {"setup_source": storable_setup_source(setup_source)} if setup_source else {}  # no password
        store = RunStore(out, {**setup.header(), **stored, "compensation": record})
        store.prepare()
    _print_compensation(active, simulate, stream)
    if simulate is not None and resume and "simulation" in store.meta:
        simulate = simulate.resumed(store.meta["simulation"])
    simulate, scenario = _scenario(simulate, setup.scenario, "positioning")
    sim = None
    live_run: Any = None
    cleanup = ExitStack()  # simulated devices, closed when the run ends
    url = setup.devices.controller_url
    environment_url = setup.devices.environment_url
    if simulate is not None:
        with _closed_on_error(cleanup):
            sim = start_simulated_machine(setup, seed=simulate.seed, noise=simulate.noise, faults=simulate.faults,
                                          start_at=rp.next_index if rp is not None else 0, scenario=scenario,
                                          device_id=_device_id(setup.devices.controller_url),
                                          compensation=active.table if active is not None else None,
                                          live_compensation=predictor is not None)
            cleanup.callback(sim.close)
            if predictor is not None:
                live_run = _start_live(predictor, sim.live_url, stream, cleanup)
            refuse_faults_that_cannot_fire(sim.faults, sensor=False, live=predictor is not None)
            url = sim.controller_url
            print(f"simulated machine axis {setup.axis_name} ({setup.trigger.mode} trigger) behind {url}",
                  file=stream)
            transmitter = _simulated_transmitter(environment_url, sim.axis, stream, cleanup)
            environment_url = transmitter.url if transmitter is not None else ""
    elif not url:
        raise SetupError("[controller] url is missing in the setup; give the controller's address or use --simulate")
    try:
        actions = {"cycle_start": sim.cycle_start} if sim is not None else {}
        operator = _operator(operator, actions, auto, stdin, stream)
        rig, open_faults = _open_devices(
            lambda: open_controller_rig(url, word_order=setup.devices.word_order,
                                        environment_url=environment_url or None, timing=setup.devices.timing),
            operator, store)
        try:
            _record_devices(store, rig, simulate, resumed=rp is not None)
            first = store.loaded_points[0] if rp is not None and store.loaded_points else None
            printer = live_deviation_printer(stream, "arcsec" if setup.axis_type == "rotary" else "um")

            def show_deviation(row: dict[str, Any], deviation: float, label: str) -> None:
                printer(row, deviation, label)
                if on_deviation is not None:
                    on_deviation(row, deviation, label)

            live = LiveDeviation(setup.axis_type, setup.environment.to_dict(), show_deviation, first)
            engine = RunEngine(rig, operator, (store, live, *subscribers))
            engine.faults_at_open = open_faults
            if live_run is not None:  # no capture starts once the compensator has stopped
                engine.subscribe(live_run)
                engine.guards.append(live_run.guard)
            with _engine_context(on_engine, engine):
                outcome = engine.run(positioning_plan(setup, {}, resume=rp))
            if sim is not None:
                _report_faults(store, sim.faults, stream)
            if live_run is not None:
                _finish_live(store, live_run, stream, sim.live_controller if sim is not None else None)
        finally:
            rig.close()
    finally:
        cleanup.close()
    _print_outcome(outcome, store, out, stream)
    stopped = live_run.stopped_run if live_run is not None else ""
    return PositioningResult(out, outcome, setup, sim, tuple(engine.faults), live, stopped)


def _live_predictor(run: Path | str | None, model: str, setup: PositioningSetup | None, simulate: SimOptions | None,
                    resume: bool) -> Any:
    """The live model of the as-found ``run`` (None without live compensation); checks the options."""
    if run is None:
        return None
    if simulate is None:
        raise SetupError("--live-compensation needs --simulate (with a real controller run guideway compensate live "
                         "RUN --controller URL next to the acquisition)")
    if resume:
        raise SetupError("--live-compensation applies to a new run; a resumed run cannot take it up")
    from .live_compensation import predictor_from_run

    predictor = predictor_from_run(run, model)
    if setup is not None and predictor.rotary != (setup.axis_type == "rotary"):
        raise SetupError(f"--live-compensation {run} is a {'rotary' if predictor.rotary else 'linear'} axis's run, "
                         f"this set-up's axis is {setup.axis_type}")
    return predictor


def _live_record(predictor: Any) -> dict[str, Any]:
    """run.json ``compensation`` of a run measured with live compensation."""
    return {"active": True, "format": "live", "file": f"live {predictor.model}", "model": predictor.model,
            "as_found_run": predictor.run, "as_found_sha256": predictor.points_sha256,
            "sha256": predictor.points_sha256, "applied_by": "simulated controller"}


@dataclass
class _LiveRun:
    """The compensator of a run, its thread (whose ``out`` receives ``error`` and ``ended_at`` when it ends) and
    the run's points seen while it ran: a subscriber of the run engine, and its guard."""

    comp: Any
    thread: Any
    out: dict[str, Any]
    points: int = 0  # points recorded (points.csv rows)
    last_time_s: float | None = None  # time_s of the last of them
    start_time_s: float | None = None  # the run's start (s since the epoch), the origin of time_s
    stopped_run: str = ""  # the guard's reason once it stopped the run

    def __call__(self, name: str, doc: dict[str, Any]) -> None:
        if name == "event":
            self.points += 1
            self.last_time_s = doc["data"].get("time_s")
        elif name == "retract":
            self.points -= 1
        elif name == "annotate" and doc.get("key") == "start_time_s":
            self.start_time_s = doc["value"]

    def cause(self) -> str:
        """Why the compensator stopped ("" while it runs)."""
        if "error" in self.out:
            return str(self.out["error"])
        return "" if self.thread.is_alive() else (self.comp.stats.reason or "the compensator ended")

    def guard(self) -> str:
        """Before each capture (:attr:`RunEngine.guards`): the reason to stop the run once the
        compensator has stopped, so no point is captured without the offset it should have."""
        cause = self.cause()
        if cause and not self.stopped_run:
            self.stopped_run = (f"live compensation stopped after point {self.points} ({cause}); the points after it "
                                "would not be compensated - the run is stopped; check the live-compensation "
                                "controller link and measure again")
        return self.stopped_run


def _start_live(predictor: Any, url: str, stream: TextIO, cleanup: ExitStack) -> _LiveRun:
    """The compensator in a thread against the simulated controller; stopped by ``cleanup``."""
    from .live_compensation import LiveCompensator, start_in_thread

    comp = LiveCompensator(predictor, url, stream=stream)
    thread, out = start_in_thread(comp)

    def stop() -> None:
        comp.stop()
        thread.join(timeout=5)

    cleanup.callback(stop)
    print(f"live compensation: {predictor.model} model of {predictor.run} against the simulated controller "
          f"at {url} (cycle {comp.cycle_s * 1000:g} ms)", file=stream)
    return _LiveRun(comp, thread, out)


def _finish_live(store: RunStore, live: _LiveRun, stream: TextIO, controller: Any = None) -> None:
    """Stop the compensator and keep what it did in run.json ``live_compensation`` (with the lag of the
    offset behind each move the simulated controller measured, ms; when it stopped during the run: why,
    when, and the last point measured while it ran)."""
    comp, thread, out = live.comp, live.thread, live.out
    comp.stop()
    thread.join(timeout=5)
    stats = comp.stats
    record: dict[str, Any] = {"model": comp.predictor.model, "cycles": stats.cycles, "overruns": stats.overruns,
                              "jumps_clamped": stats.jumps_clamped, "ended": stats.reason or "running"}
    lags = sorted(controller.lags_s) if controller is not None else []
    if lags:
        record["lag_ms_median"] = round(1000 * lags[len(lags) // 2], 3)
        record["lag_ms_max"] = round(1000 * lags[-1], 3)
    if "error" in out or live.stopped_run:
        record["error"] = live.cause()
        record["ended"] = stats.reason or "stopped during the run"
        if live.start_time_s is not None and "ended_at" in out:
            record["stopped_time_s"] = round(out["ended_at"] - live.start_time_s, 6)  # the origin of time_s
        record["last_compensated_point"] = live.points  # points.csv row (1-based); 0: none
        record["last_compensated_time_s"] = live.last_time_s
        if not live.stopped_run:  # it stopped after the last capture: every point was compensated
            print(f"warning: live compensation stopped after the last point: {out['error']}", file=stream)
    store("annotate", {"key": "live_compensation", "value": record})


def _applied_by(simulate: SimOptions | None) -> str:
    return "simulated controller" if simulate is not None else "controller (as the set-up states)"


def _compensation(setup: PositioningSetup, simulate: SimOptions | None,
                  stored: dict[str, Any] | None) -> ActiveCompensation | None:
    """The set-up's ``[compensation]`` read as its controller reads it; a resumed run (``stored``: its
    run.json) must have the very file it started with (the same SHA-256)."""
    active = load_compensation(setup.compensation, setup) if setup.compensation is not None else None
    if stored is not None:
        before = stored.get("compensation")
        if isinstance(before, dict) and before.get("active") and (active is None or
                                                                 active.sha256 != before.get("sha256")):
            raise SetupError(f"the run started with compensation table {before.get('path')} (sha256 "
                             f"{str(before.get('sha256'))[:12]}…), which is no longer there as it was; restore it "
                             "to resume, or start a new run")
    return active


def _print_compensation(active: ActiveCompensation | None, simulate: SimOptions | None, stream: TextIO) -> None:
    if active is None:
        return
    who = "the simulated controller applies it" if simulate is not None else (
        "recorded as loaded in the controller; the tool does not load it")
    print(f"compensation: {active.setup.file} ({active.table.description()}, sha256 {active.sha256[:12]}…): {who}",
          file=stream)
    for note in active.notes:
        print(f"note: {note}", file=stream)


def acquire(kind: str, source: dict[str, Any] | None, source_name: str, out: Path | str, *,
            simulate: SimOptions | None = None, auto: bool = False, resume: bool = False,
            **kwargs: Any) -> AcquireResult | PositioningResult:
    """Acquire (or resume) a run of ``kind`` from a set-up's TOML structure ``source`` (None: resume
    with the set-up stored in the run): ``guideway acquire`` and the TUI both start runs here.

    ``kwargs`` go to :func:`run_straightness` / :func:`run_positioning` (operator, subscribers, ...).
    A completed run adds itself to the catalogue of the set-up's ``[catalog] url`` or ``GUIDEWAY_CATALOG``.
    """
    res: AcquireResult | PositioningResult
    if kind == "straightness":
        setup = straightness_setup_from_dict(source, source_name) if source is not None else None
        res = run_straightness(setup, out, simulate=simulate, auto=auto, resume=resume, **kwargs)
    elif kind == "positioning":
        psetup = positioning_setup_from_dict(source, source_name) if source is not None else None
        res = run_positioning(psetup, out, simulate=simulate, auto=auto, resume=resume, setup_source=source,
                              **kwargs)
    else:
        raise SetupError(f"unknown run kind {kind!r}; use straightness or positioning")
    if res.outcome.exit_status == "success":  # a completed run adds itself to a configured catalogue
        add_completed_run(res.run_dir, setup_catalog_url(source), kwargs.get("stream", sys.stdout))
    return res
