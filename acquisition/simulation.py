"""Composition root of a simulated session: the only runtime module that
imports ``mocks``.

It builds one simulated world, puts a displacement-sensor emulator (one of
:data:`SENSOR_EMULATORS`) behind a real pseudo-terminal and a Modbus
interferometer controller on 127.0.0.1 (TCP, or RTU framing over TCP), and
returns their endpoints.  Everything downstream opens those endpoints with the
real drivers, exactly as on a real rig.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pymodbus import FramerType

from mocks.faults import FaultPlan, FaultSpecError
from mocks.interferometer import InterferometerEmulator, ModbusServerThread, start_controller
from mocks.keyence_lkg import KeyenceLKGEmulator
from mocks.machine_axis import AxisErrors, InPositionRegisters, MachineAxis, MachineStop
from mocks.serial_endpoints import ByteEmulator, PtyEndpoint
from mocks.world import BlockSetup, Noise, World
from processing.geometry import BlockGeometry

from .errors import UserError
from .positioning_setup import PositioningSetup, SimulatedAxisSetup

SensorSource = Callable[..., float | None]
"""What a sensor emulator reads: ``source(output=1)`` gives the displacement in mm
(height sign: closer target -> larger) for an output/head number, ``None`` when
the beam sees no target.  Emulators of single-output heads may call ``source()``."""


@dataclass(frozen=True)
class SensorEmulator:
    """How to build one sensor family's emulator.

    ``factory(source, faults=plan)`` returns a byte-in/byte-out emulator
    (``receive(bytes) -> bytes``); an emulator class with the constructor
    ``(source, *, faults=None)`` is a factory as it stands.  ``baudrate`` is the
    line rate the endpoint models and the driver is opened with.
    """

    factory: Callable[..., ByteEmulator]
    baudrate: int


# Protocol name (as in acquisition.rig.SENSOR_DRIVERS) -> emulator; one line per sensor family.
SENSOR_EMULATORS: dict[str, SensorEmulator] = {
    "keyence-lkg": SensorEmulator(KeyenceLKGEmulator, 115200),
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

    def geometry(self) -> BlockGeometry:
        """The set-up geometry a technician would measure on this rig (nominal values)."""
        b = self.world.block
        e = b.sensor_head_mm
        q = tuple(e[i] + b.standoff_mm * b.beam[i] for i in range(3))
        return BlockGeometry(
            mirror_mm=b.mirror_mm, sensor_mm=q, sensor_beam=b.beam, sensor_sign="height"  # type: ignore[arg-type]
        )

    def place_block(self, station: int, **_: Any) -> None:
        """What the simulated technician does when asked to move the block (any pass)."""
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
            self.world.beam_blocked = words[1] == "off"
            return f"beam {words[1]}"
        if words[0] == "help" and len(words) == 1:
            return "commands: station N | beam off | beam on | help"
        return f"unknown command {line.strip()!r}; commands: station N | beam off | beam on | help"

    def close(self) -> None:
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

def default_block() -> tuple[float, BlockGeometry]:
    """Block length (mm) and set-up geometry of the default simulated rig."""
    b = BlockSetup()
    q = tuple(b.sensor_head_mm[i] + b.standoff_mm * b.beam[i] for i in range(3))
    return b.length_mm, BlockGeometry(mirror_mm=b.mirror_mm, sensor_mm=q, sensor_beam=b.beam,  # type: ignore[arg-type]
                                      sensor_sign="height")


def _block_for(length_mm: float, geometry: BlockGeometry) -> BlockSetup:
    """A simulated block built to match a set-up: mirror at P, sensor reading 0 at Q."""
    standoff = BlockSetup().standoff_mm
    head = tuple(geometry.sensor_mm[i] - standoff * geometry.sensor_beam[i] for i in range(3))
    return BlockSetup(length_mm=length_mm, mirror_mm=geometry.mirror_mm, sensor_head_mm=head,  # type: ignore[arg-type]
                      beam=geometry.sensor_beam, standoff_mm=standoff)



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
    emulators, for benchmarks).
    """
    if controller not in CONTROLLER_TRANSPORTS:
        raise UserError(f"controller transport {controller!r}: use one of {', '.join(CONTROLLER_TRANSPORTS)}")
    kind = sensor_emulator(sensor)
    plan = parse_faults(faults)
    baud = baudrate or kind.baudrate
    sign = 1.0
    block = None
    if block_length_mm is not None or geometry is not None:
        d_len, d_geo = default_block()
        geometry = geometry or d_geo
        block = _block_for(block_length_mm or d_len, geometry)
        sign = 1.0 if geometry.sensor_sign == "height" else -1.0
    world = World(seed=seed, noise=Noise() if noise else Noise.off(), block=block)
    block = world.block

    def sensor_value(_output: int = 1) -> float | None:
        d = world.sensor_distance_mm()
        # height sign: the surface closer -> larger; gap sign: the opposite
        return None if d is None else sign * (block.standoff_mm - d)

    pty = PtyEndpoint(kind.factory(sensor_value, faults=plan), baudrate=baud if wire_time else 0, faults=plan,
                      link=sensor_link)
    try:
        emulator = InterferometerEmulator(world, measure_time_s=measure_time_s, faults=plan)
        if controller == "rtu-over-tcp":
            modbus = ModbusServerThread(emulator.device(), port=modbus_port, framer=FramerType.RTU,
                                        wire_faults=emulator.wire_faults)
        else:
            modbus = start_controller(emulator, transport=controller, port=modbus_port)
    except BaseException as exc:
        pty.stop()
        if isinstance(exc, RuntimeError) and modbus_port:
            raise UserError(f"cannot serve Modbus on port {modbus_port} ({exc}); choose another --modbus-port") from exc
        raise
    controller_url = f"modbus-rtu:socket://127.0.0.1:{modbus.port}" if controller == "rtu-over-tcp" else modbus.url
    sensor_url = str(sensor_link) if sensor_link is not None else pty.path
    return SimulatedRig(world, sensor, sensor_url, controller_url, pty, modbus, baud, plan)


@dataclass
class SimulatedMachine:
    """A simulated machine axis running the set-up's cycle behind a Modbus TCP interferometer controller."""

    axis: MachineAxis
    controller_url: str
    _modbus: ModbusServerThread

    def cycle_start(self, **_: Any) -> None:
        """What the simulated technician does when asked to press Cycle Start."""
        self.axis.cycle_start()

    def close(self) -> None:
        self._modbus.stop()


HANDSHAKE = {"in-position": "ack", "manual": "cycle-start", "stability": "timed"}


def _axis_errors(setup: PositioningSetup, noise: bool) -> AxisErrors:
    sim = setup.simulation
    if setup.axis_type == "rotary" and sim == SimulatedAxisSetup():
        # rotary defaults (arcsec): a once-per-revolution error, a 90-tooth worm's periodic error
        return AxisErrors(pitch=((4.0, 360.0, 0.7),), slope_per_m=0.0, backlash=2.0, periodic=1.0,
                          periodic_period=4.0, thermal_per_m_per_h=0.0, noise=0.3 if noise else 0.0)
    return AxisErrors(pitch=((sim.pitch_amplitude, sim.pitch_wavelength, 0.4),), slope_per_m=sim.slope_per_m,
                      backlash=sim.backlash, periodic=sim.periodic, periodic_period=sim.periodic_period,
                      thermal_per_m_per_h=sim.thermal_per_m_per_h, noise=sim.noise if noise else 0.0)


def start_simulated_machine(setup: PositioningSetup, *, seed: int = 0, noise: bool = True,
                            faults: str | None = None, start_at: int = 0) -> SimulatedMachine:
    """Start a machine axis that runs exactly the set-up's cycle, read by a Modbus TCP controller.

    The in-position handshake follows the trigger mode: the PLC waits for the tool's acknowledge
    (in-position), for Cycle Start (manual, M00 at each target) or for the dwell time (stability).
    ``start_at``: the program is restarted at the block of that measured stop (0-based; resume).
    """
    plan = parse_faults(faults)
    stops = [MachineStop(s.position, s.target_index, s.run, s.direction) for s in setup.stops()]
    axis = MachineAxis(stops, rotary=setup.axis_type == "rotary", errors=_axis_errors(setup, noise),
                       feed_per_min=setup.feed_per_min, dwell_s=setup.trigger.dwell_s,
                       handshake=HANDSHAKE[setup.trigger.mode], datum=setup.datum, seed=seed)
    emulator = InterferometerEmulator(axis, word_order=setup.devices.word_order, faults=plan,  # type: ignore[arg-type]
                                      extension=InPositionRegisters(axis, setup.devices.word_order))
    if start_at:
        measured = [k for k, s in enumerate(stops) if s.target_index]
        axis.index = measured[min(start_at, len(measured) - 1)] - 1  # restart: the next block is that target
        axis.commanded = stops[axis.index].position
    modbus = ModbusServerThread(emulator.device())
    return SimulatedMachine(axis, modbus.url, modbus)
