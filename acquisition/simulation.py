"""Composition root of a simulated session: the only runtime module that
imports ``mocks``.

It builds one simulated world, puts a displacement-sensor emulator (one of
:data:`SENSOR_EMULATORS`) behind a real pseudo-terminal and a Modbus
interferometer controller on 127.0.0.1 (TCP, or RTU framing over TCP), and
returns their endpoints.  Everything downstream opens those endpoints with the
real drivers, exactly as on a real rig.
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

from pymodbus import FramerType

from mocks.effects import AngularMotion, AxisEffects, Conditions, SensorEffects, straightness_parts
from mocks.faults import FaultPlan, FaultSpecError
from mocks.interferometer import InterferometerEmulator, ModbusServerThread, start_controller
from mocks.keyence_lkg import KeyenceLKGEmulator
from mocks.machine_axis import AxisErrors, InPositionRegisters, LinearOptics, MachineAxis, MachineStop
from mocks.me_ild1420 import ILD1420Emulator, StreamPacer
from mocks.offline import StepClock, axis_captures, world_captures
from mocks.panasonic_hlg1 import PanasonicHLG1Emulator
from mocks.serial_endpoints import ByteEmulator, PtyEndpoint
from mocks.world import BlockSetup, Environment, Guideway, Noise, Wave, World
from mocks.xymd02 import XYMD02Emulator, start_xymd02, world_source
from processing.environment import EnvironmentSettings
from processing.geometry import BlockGeometry, SensorSign

from .errors import UserError
from .positioning_setup import PositioningSetup, SimulatedAxisSetup

if TYPE_CHECKING:
    from .scenario import Scenario

SensorSource = Callable[..., float | None]
"""What a sensor emulator reads: ``source(output=1)`` gives the value in mm in the
emulator's own convention (see :attr:`SensorEmulator.reading`) for an output/head
number, ``None`` when the beam sees no target.  Emulators of single-output heads
may call ``source()``."""


class Stream(Protocol):
    """A running value stream of a streaming sensor's emulator."""

    def stop(self) -> None: ...


def _same(height_mm: float) -> float:
    return height_mm


ILD1420_RANGE_MM = 10.0
"""Measuring range MR of the simulated ILD1420 (an ILD1420-10, the emulator's default head)."""


def ild1420_distance_mm(height_mm: float) -> float:
    """ILD1420 value for a surface height: distance from the start of the range, mid-range at height 0.

    The 1420 reports 0...MR with larger = surface further away (a gap-type reading).
    """
    return ILD1420_RANGE_MM / 2 - height_mm


def _ild1420_stream(emulator: ILD1420Emulator, write: Callable[[bytes], None], ready: Callable[[], bool]
                    ) -> Stream:
    # at the emulator's measuring rate (1 kHz here; a MEASRATE command changes it)
    return StreamPacer(emulator, write, ready=ready).start()


@dataclass(frozen=True)
class SensorEmulator:
    """How to build one sensor family's emulator.

    ``factory(source, faults=plan)`` returns a byte-in/byte-out emulator
    (``receive(bytes) -> bytes``); an emulator class with the constructor
    ``(source, *, faults=None)`` is a factory as it stands.  ``baudrate`` is the
    line rate the endpoint models and the driver is opened with.
    ``reading(height_mm)`` turns the world's surface height at the sensor (mm,
    height sign: closer -> larger, 0 at the set-up's sensor point) into the
    value the emulator reports; ``sensor_sign`` is the sign that value has
    (``height`` or ``gap``, as in :class:`~processing.geometry.BlockGeometry`).
    ``stream(emulator, write, ready)``: for a streaming sensor, starts pushing
    its values through ``write`` while ``ready()`` (the line takes bytes) and
    returns something to ``stop()``.
    """

    factory: Callable[..., ByteEmulator]
    baudrate: int
    reading: Callable[[float], float] = _same
    sensor_sign: SensorSign = "height"
    stream: Callable[[Any, Callable[[bytes], None], Callable[[], bool]], Stream] | None = None


# Protocol name (as in acquisition.rig.SENSOR_DRIVERS) -> emulator; one entry per sensor family.
SENSOR_EMULATORS: dict[str, SensorEmulator] = {
    "keyence-lkg": SensorEmulator(KeyenceLKGEmulator, 115200),
    # a signed value in 0.0001 mm around the head's reference distance
    "panasonic-hlg1": SensorEmulator(PanasonicHLG1Emulator, 115200),
    # RS-422 at the factory rate of 921.6 kBd; streams its values while OUTPUT RS422 (power-up)
    "me-ild1420": SensorEmulator(partial(ILD1420Emulator, measuring_range_mm=ILD1420_RANGE_MM, measrate_khz=1.0),
                                 921600,
                                 reading=ild1420_distance_mm, sensor_sign="gap", stream=_ild1420_stream),
}


CONTROLLER_TRANSPORTS = ("tcp", "rtu", "rtu-over-tcp")


@dataclass
class SimulatedRig:
    """Running emulators, their endpoints and the world behind them."""

    world: World
    sensor_protocol: str
    sensor_url: str
    controller_url: str
    _pty: PtyEndpoint
    _modbus: ModbusServerThread
    sensor_baudrate: int = 115200
    faults: FaultPlan | None = None
    sensor_sign: SensorSign = "height"  # the sign the simulated sensor's values really have
    _stream: Stream | None = field(default=None, repr=False)
    # held while the world changes: a streaming head sends no burst sampled partly before the change
    _sampling: contextlib.AbstractContextManager[Any] = field(default_factory=contextlib.nullcontext, repr=False)

    def geometry(self) -> BlockGeometry:
        """The set-up geometry a technician would measure on this rig (nominal values, the sensor's sign)."""
        return _geometry_of(self.world.block, self.sensor_sign)

    def place_block(self, station: int, **_: Any) -> None:
        """What the simulated technician does when asked to move the block (any pass)."""
        with self._sampling:
            self.world.place_block(station)

    def sensor_path(self) -> str:
        """The pty the sensor emulator currently serves (changes after a ``close`` fault)."""
        return self._pty.path

    def command(self, line: str) -> str:
        """Act on one operator command typed at ``guideway sim serve``; return the answer line.

        ``station N`` moves the block to station N; ``beam off`` / ``beam on``
        blocks / clears the beams; ``help`` lists the commands.
        """
        words = line.split()
        if not words:
            return ""
        if words[0] == "station" and len(words) == 2 and words[1].isdigit():
            n = int(words[1])
            self.place_block(n)
            return f"block at station {n} (x = {self.world.nominal_x_mm(n):.3f} mm)"
        if words[0] == "beam" and len(words) == 2 and words[1] in ("on", "off"):
            with self._sampling:
                self.world.beam_blocked = words[1] == "off"
            return f"beam {words[1]}"
        if words[0] == "help" and len(words) == 1:
            return "commands: station N | beam off | beam on | help"
        return f"unknown command {line.strip()!r}; commands: station N | beam off | beam on | help"

    def close(self) -> None:
        if self._stream is not None:
            self._stream.stop()
        self._modbus.stop()
        self._pty.stop()


def sensor_emulator(protocol: str) -> SensorEmulator:
    """The registered emulator of a sensor protocol; a :class:`UserError` naming the choices."""
    try:
        return SENSOR_EMULATORS[protocol]
    except KeyError:
        raise UserError(
            f"no simulated sensor {protocol!r}; use one of: {', '.join(SENSOR_EMULATORS)}"
        ) from None


def parse_faults(spec: str | None) -> FaultPlan:
    """A fault plan from a ``--faults`` spec; a one-line :class:`UserError` when malformed."""
    try:
        return FaultPlan.parse(spec)
    except FaultSpecError as exc:
        raise UserError(str(exc)) from exc


# Sensor requests per averaged sample in a run: the LK-G and HL-G1 drivers poll one value per
# command line; the ILD1420 streams its values (no request; its commands are sent at open only).
# tests/acquisition/test_fault_plans.py counts them on the simulated devices.
REQUESTS_PER_SAMPLE = {"keyence-lkg": 1, "panasonic-hlg1": 1, "me-ild1420": 0}


def refuse_faults_that_cannot_fire(plan: FaultPlan | None, *, sensor: bool, sensor_requests: int | None = None
                                   ) -> None:
    """A one-line :class:`UserError` for fault entries that certainly cannot fire.

    ``sensor`` False: the run has no displacement sensor, so no sensor entry can fire.
    ``sensor_requests``: how many requests the sensor gets in a fault-free run (None: not known,
    e.g. an operator may redo stations).  Requests beyond it come only from retries after a fault,
    so when every entry is a sensor entry past it, none can fire.  Anything less certain is left
    to :func:`fault_report` at the end of the run."""
    if plan is None or not plan.faults:
        return
    if not sensor:
        f = next((f for f in plan.faults if f.device == "sensor"), None)
        if f is not None:
            raise UserError(f"--faults {f.spec()} cannot fire: this run has no displacement sensor; "
                            "inject controller faults")
        return
    if sensor_requests is not None and all(f.device == "sensor" and f.at > sensor_requests for f in plan.faults):
        f = plan.faults[0]
        raise UserError(f"--faults {f.spec()} cannot fire: a run of this set-up asks the sensor {sensor_requests} "
                        f"times; give N <= {sensor_requests}")


def fault_report(plan: FaultPlan | None) -> dict[str, Any] | None:
    """run.json ``fault_plan``: the spec, the requests each device got and the entries that did
    not fire (None without faults)."""
    if plan is None or not plan.faults:
        return None
    return {"spec": ",".join(f.spec() for f in plan.faults),
            "requests": {d: plan.requests(d) for d in ("sensor", "controller")},
            "not_fired": [f.spec() for f in plan.unfired()]}


def _geometry_of(b: BlockSetup, sign: SensorSign) -> BlockGeometry:
    """Nominal set-up geometry of a simulated block: mirror at P, sensor point Q at the stand-off."""
    q = tuple(b.sensor_head_mm[i] + b.standoff_mm * b.beam[i] for i in range(3))
    return BlockGeometry(mirror_mm=b.mirror_mm, sensor_mm=q, sensor_beam=b.beam,  # type: ignore[arg-type]
                         sensor_sign=sign)


def default_block(sensor: str = "keyence-lkg") -> tuple[float, BlockGeometry]:
    """Block length (mm) and set-up geometry of the default simulated rig with a ``sensor`` head.

    The geometry's ``sensor_sign`` is the one the family's simulated values have.
    """
    b = BlockSetup()
    return b.length_mm, _geometry_of(b, sensor_emulator(sensor).sensor_sign)


def _block_for(length_mm: float, geometry: BlockGeometry) -> BlockSetup:
    """A simulated block built to match a set-up: mirror at P, sensor reading 0 at Q."""
    standoff = BlockSetup().standoff_mm
    head = tuple(geometry.sensor_mm[i] - standoff * geometry.sensor_beam[i] for i in range(3))
    return BlockSetup(length_mm=length_mm, mirror_mm=geometry.mirror_mm, sensor_head_mm=head,  # type: ignore[arg-type]
                      beam=geometry.sensor_beam, standoff_mm=standoff)



SAMPLE_LOG_LIMIT = 4096


def bound_sample_log(world: World) -> None:
    """Keep the world's record of sensor samples bounded (a streaming head samples at kHz rates for
    as long as ``sim serve`` runs): past the limit, only the newest sample of each station stays."""
    log = world.sample_log
    if len(log) > SAMPLE_LOG_LIMIT:
        log[:] = list(dict(log).items())


def start_simulated_rig(
    *,
    seed: int = 0,
    noise: bool = True,
    sensor: str = "keyence-lkg",
    measure_time_s: float = 0.0,
    baudrate: int | None = None,
    faults: str | None = None,
    controller: str = "tcp",
    modbus_port: int = 0,
    sensor_link: str | Path | None = None,
    block_length_mm: float | None = None,
    geometry: BlockGeometry | None = None,
    wire_time: bool = True,
    scenario: Scenario | None = None,
    device_id: int = 1,
) -> SimulatedRig:
    """Start the emulators on real transports and return their endpoints.

    ``sensor`` names a protocol of :data:`SENSOR_EMULATORS`; ``baudrate``
    defaults to that protocol's rate.  ``faults`` is a fault-plan spec (see
    :mod:`mocks.faults`), e.g. ``"sensor:garbage@12"``.  ``controller``:
    ``"tcp"`` (Modbus TCP on 127.0.0.1, ``modbus_port`` 0 picks a free port),
    ``"rtu"`` (Modbus RTU on a pty pair at 115200 baud, driver URL
    ``modbus-rtu:/dev/pts/N?...``) or ``"rtu-over-tcp"`` (RTU frames over TCP,
    driver URL ``modbus-rtu:socket://127.0.0.1:PORT``).  ``sensor_link``: a path
    kept as a symlink to the sensor's pty (stable across a ``close`` fault).
    ``block_length_mm`` and ``geometry`` build the simulated block to match a
    set-up file (default: :func:`default_block`).  ``wire_time=False``: the
    sensor answers without the serial line's transfer time (zero-latency
    emulators, for benchmarks).  ``scenario``: a straightness scenario whose
    effects, surface and noise the simulated world and sensor take on.  ``device_id``: the Modbus
    unit id the controller answers at (only there, like a controller behind a gateway); the
    controller URL carries it.
    """
    if controller not in CONTROLLER_TRANSPORTS:
        raise UserError(f"controller transport {controller!r}: use one of {', '.join(CONTROLLER_TRANSPORTS)}")
    kind = sensor_emulator(sensor)
    plan = parse_faults(faults)
    baud = baudrate or kind.baudrate
    sensor_sign = kind.sensor_sign
    block = None
    if block_length_mm is not None or geometry is not None:
        d_len, d_geo = default_block(sensor)
        geometry = geometry or d_geo
        block = _block_for(block_length_mm or d_len, geometry)
        # the head is set up (mounted, or its output inverted) to read with the set-up's sign
        sensor_sign = geometry.sensor_sign
    flip = 1.0 if sensor_sign == kind.sensor_sign else -1.0
    sensor_fx, started = SensorEffects(), time.monotonic()
    if scenario is not None:
        world, sensor_fx = _scenario_world(scenario, block or BlockSetup(), seed, noise)
    else:
        world = World(seed=seed, noise=Noise() if noise else Noise.off(), block=block)
    block = world.block

    def sensor_value(_output: int = 1) -> float | None:
        d = world.sensor_distance_mm()
        bound_sample_log(world)
        if d is None:
            return None
        # surface height at the sensor (height sign: the surface closer -> larger), as the family reports it
        return kind.reading(flip * sensor_fx.reading_mm(block.standoff_mm - d, (time.monotonic() - started) / 60))

    emulator = kind.factory(sensor_value, faults=plan)
    pty = PtyEndpoint(emulator, baudrate=baud if wire_time else 0, faults=plan, link=sensor_link)
    stream = None
    if kind.stream is not None:
        def write(data: bytes) -> None:
            with contextlib.suppress(OSError):  # the pty is being replaced (close fault) or stopped
                pty.write_unsolicited(data, drop_when_full=True)

        stream = kind.stream(emulator, write, pty.writable)
    sampling = getattr(emulator, "lock", None) if stream is not None else None
    try:
        emulator = InterferometerEmulator(world, measure_time_s=measure_time_s, faults=plan)
        if controller == "rtu-over-tcp":
            modbus = start_controller(emulator, transport="tcp", framer=FramerType.RTU, port=modbus_port,
                                      device_id=device_id)
        else:
            modbus = start_controller(emulator, transport=controller, port=modbus_port, device_id=device_id)
    except BaseException as exc:
        if stream is not None:
            stream.stop()
        pty.stop()
        if isinstance(exc, RuntimeError) and modbus_port:
            raise UserError(f"cannot serve Modbus on port {modbus_port} ({exc}); choose another --modbus-port") from exc
        raise
    controller_url = modbus.url
    if controller == "rtu-over-tcp":
        controller_url = f"modbus-rtu:socket://127.0.0.1:{modbus.port}" + ("" if device_id == 1 else
                                                                           f"?device_id={device_id}")
    sensor_url = str(sensor_link) if sensor_link is not None else pty.path
    return SimulatedRig(world, sensor, sensor_url, controller_url, pty, modbus, baud, plan, sensor_sign, stream,
                        sampling or contextlib.nullcontext())


@dataclass
class SimulatedMachine:
    """A simulated machine axis running the set-up's cycle behind a Modbus TCP interferometer controller."""

    axis: MachineAxis
    controller_url: str
    _modbus: ModbusServerThread
    faults: FaultPlan | None = None

    def cycle_start(self, **_: Any) -> None:
        """What the simulated technician does when asked to press Cycle Start."""
        self.axis.cycle_start()

    def close(self) -> None:
        self._modbus.stop()


HANDSHAKE = {"in-position": "ack", "manual": "cycle-start", "stability": "timed"}


def _environment(sim: SimulatedAxisSetup) -> Environment:
    return Environment(air_temp_c=sim.air_temp_c, air_pressure_hpa=sim.air_pressure_hpa,
                       humidity_pct=sim.humidity_pct, material_temp_c=sim.material_temp_c,
                       drift_c_per_h=sim.drift_c_per_h)


def _axis_errors(setup: PositioningSetup, noise: bool) -> AxisErrors:
    sim = setup.simulation
    if setup.axis_type == "rotary" and sim.errors() == SimulatedAxisSetup().errors():
        # rotary defaults (arcsec): a once-per-revolution error, a 90-tooth worm's periodic error
        return AxisErrors(pitch=((4.0, 360.0, 0.7),), slope_per_m=0.0, backlash=2.0, periodic=1.0,
                          periodic_period=4.0, thermal_per_m_per_h=0.0, noise=0.3 if noise else 0.0)
    return AxisErrors(pitch=((sim.pitch_amplitude, sim.pitch_wavelength, 0.4),), slope_per_m=sim.slope_per_m,
                      backlash=sim.backlash, periodic=sim.periodic, periodic_period=sim.periodic_period,
                      thermal_per_m_per_h=sim.thermal_per_m_per_h, noise=sim.noise if noise else 0.0)


def _optics(setup: PositioningSetup) -> LinearOptics:
    """The controller's reading model from the set-up's [environment], read the way processing reads it."""
    try:
        env = EnvironmentSettings.from_dict(setup.environment.to_dict())
    except ValueError as exc:
        raise UserError(f"[environment]: {exc}") from None
    return LinearOptics(expansion_ppm_per_k=env.expansion_ppm_per_k,
                        refractive_index_assumed=env.refractive_index_assumed or 1.0,
                        wavelength_nm=env.wavelength_nm, co2_ppm=env.co2_ppm, index_equation=env.index_equation,
                        dead_path_mm=env.dead_path_mm, readings_compensated=env.readings_compensated)


def start_simulated_machine(setup: PositioningSetup, *, seed: int = 0, noise: bool = True,
                            faults: str | None = None, start_at: int = 0, device_id: int = 1,
                            scenario: Scenario | None = None) -> SimulatedMachine:
    """Start a machine axis that runs exactly the set-up's cycle, read by a Modbus TCP controller
    (at unit id ``device_id``).

    The in-position handshake follows the trigger mode: the PLC waits for the tool's acknowledge
    (in-position), for Cycle Start (manual, M00 at each target) or for the dwell time (stability).
    ``start_at``: the program is restarted at the block of that measured stop (0-based; resume).
    ``[simulation] plc_bits_left_set`` / ``program_start_s``: a PLC that left *in position* and
    *cycle finished* set from an earlier cycle, and a program that reaches its first block that long
    after Cycle Start (docs/modbus-map.md).
    ``scenario``: a positioning scenario replaces the set-up's ``[simulation]`` errors and conditions
    by its effects, conditions, angular motion and noise (its time-dependent effects run on the wall
    clock, as the run's ``time_s`` does).
    """
    plan = parse_faults(faults)
    stops = [MachineStop(s.position, s.target_index, s.run, s.direction) for s in setup.stops()]
    if scenario is not None:
        if setup.axis_type != "linear":
            raise UserError("a scenario simulates a linear axis; the set-up is for a rotary one")
        model: dict[str, Any] = {**_scenario_axis(scenario, noise), "wall_clock_effects": True}
    else:
        model = {"errors": _axis_errors(setup, noise), "environment": _environment(setup.simulation)}
    axis = MachineAxis(stops, rotary=setup.axis_type == "rotary", feed_per_min=setup.feed_per_min,
                       dwell_s=setup.trigger.dwell_s, handshake=HANDSHAKE[setup.trigger.mode], datum=setup.datum,
                       seed=seed, optics=_optics(setup), bits_left_set=setup.simulation.plc_bits_left_set,
                       program_start_s=setup.simulation.program_start_s, **model)
    emulator = InterferometerEmulator(axis, word_order=setup.devices.word_order, faults=plan,  # type: ignore[arg-type]
                                      extension=InPositionRegisters(axis, setup.devices.word_order))
    if start_at:
        measured = [k for k, s in enumerate(stops) if s.target_index]
        axis.index = measured[min(start_at, len(measured) - 1)] - 1  # restart: the next block is that target
        axis.commanded = stops[axis.index].position
    modbus = start_controller(emulator, device_id=device_id)
    return SimulatedMachine(axis, modbus.url, modbus, plan)


@dataclass
class SimulatedTransmitter:
    """An XY-MD02 air temperature / humidity transmitter on Modbus RTU (pty), reading the
    environment of a simulated world or machine axis."""

    url: str
    _server: ModbusServerThread

    def close(self) -> None:
        self._server.stop()


def start_simulated_transmitter(environment: World | MachineAxis) -> SimulatedTransmitter:
    """Serve an XY-MD02 emulator fed by ``environment.environment_now()``; ``.url`` opens it."""
    server = start_xymd02(XYMD02Emulator(world_source(environment)))  # type: ignore[arg-type]
    return SimulatedTransmitter(server.url, server)


# -- scenarios (acquisition/scenario.py): effects put behind the simulated devices -----------------------------
def _scenario_axis(scenario: Scenario, noise: bool) -> dict[str, Any]:
    """MachineAxis arguments of a positioning scenario: no built-in errors, its effects and conditions."""
    n = scenario.noise
    c = scenario.conditions
    return {
        "errors": AxisErrors(pitch=(), slope_per_m=0.0, backlash=0.0, periodic=0.0, thermal_per_m_per_h=0.0,
                             noise=n["reading_um"] if noise else 0.0),
        "environment": Conditions(**c),
        "effects": AxisEffects(scenario.effect_specs(), AngularMotion(**scenario.motion),
                               n["angle_urad"] if noise else 0.0),
    }


def _scenario_world(scenario: Scenario, recorded: BlockSetup, seed: int, noise: bool,
                    clock: Callable[[], float] = time.monotonic) -> tuple[World, SensorEffects]:
    """The simulated world of a straightness scenario built around the ``recorded`` block, and the sensor's
    own effects."""
    base = Guideway.from_seed(seed)
    if scenario.surface is not None:
        base = Guideway(waves=tuple(Wave(*w) for w in scenario.surface["waves"]),
                        slope_urad=scenario.surface["slope_urad"])
    block, surface, sensor = straightness_parts(scenario.effect_specs(), recorded, base)
    world = World(guideway=surface, block=block, noise=Noise(**scenario.noise) if noise else Noise.off(),
                  seed=seed, clock=clock)
    return world, sensor


def simulate_positioning_points(scenario: Scenario, seed: int, noise: bool = True) -> list[dict[str, Any]]:
    """points.csv records of a positioning run of ``scenario`` (docs/run-format.md), the machine axis
    driven through the scenario's cycle without transports; ``time_s`` is machine time."""
    setup = scenario.positioning
    assert setup is not None
    stops = [MachineStop(s.position, s.target_index, s.run, s.direction) for s in setup.stops()]
    axis = MachineAxis(stops, feed_per_min=setup.feed_per_min, dwell_s=setup.trigger.dwell_s, handshake="ack",
                       datum=setup.datum, seed=seed, optics=_optics(setup), **_scenario_axis(scenario, noise))
    rows = []
    for rec in axis_captures(axis):
        stop, c, env = rec["stop"], rec["capture"], rec["environment"]
        rows.append({"run": stop.run, "direction": stop.direction, "target_index": stop.target_index,
                     "target_mm": stop.position, "reading_mm": setup.datum + c.position_mm, "time_s": rec["time_s"],
                     "stry_um": c.stry_um, "strz_um": c.strz_um, "pitch_urad": c.pitch_urad,
                     "yaw_urad": c.yaw_urad, "roll_urad": c.roll_urad, "air_temp_c": env[0],
                     "air_pressure_hpa": env[1], "humidity_pct": env[2], "material_temp_c": env[3]})
    return rows


def simulate_straightness_points(scenario: Scenario, seed: int, noise: bool = True) -> list[dict[str, Any]]:
    """points.csv records of a straightness run of ``scenario`` (the gauge block placed by the simulated
    technician, ``seconds_per_station`` apart, the sensor read with the set-up's sign)."""
    setup = scenario.straightness
    assert setup is not None
    clock = StepClock()
    world, sensor = _scenario_world(scenario, _block_for(setup.block_length_mm, setup.geometry), seed, noise,
                                    clock)
    sign = 1.0 if setup.geometry.sensor_sign == "height" else -1.0
    rows = []
    for rec in world_captures(world, clock, setup.steps(), samples=setup.samples_per_reading,
                              seconds_per_step=scenario.timing["seconds_per_station"], sensor=sensor):
        c, env, k = rec["capture"], rec["environment"], rec["station"]
        x = setup.station_x_mm(k)
        rows.append({"station": k, "x_mm": x, "time_s": rec["time_s"], "lin_um": (c.position_mm - x) * 1000.0,
                     "stry_um": c.stry_um, "strz_um": c.strz_um, "pitch_urad": c.pitch_urad, "yaw_urad": c.yaw_urad,
                     "roll_urad": c.roll_urad, "sensor_mm": sign * rec["sensor_mm"], "air_temp_c": env[0],
                     "air_pressure_hpa": env[1], "humidity_pct": env[2], "material_temp_c": env[3],
                     "pass": rec["pass"]})
    return rows
