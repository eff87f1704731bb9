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

from pymodbus import FramerType

from mocks.faults import FaultPlan, FaultSpecError
from mocks.interferometer import InterferometerEmulator, ModbusServerThread, start_controller
from mocks.keyence_lkg import KeyenceLKGEmulator
from mocks.serial_endpoints import ByteEmulator, PtyEndpoint
from mocks.world import Noise, World
from processing.geometry import BlockGeometry

from .errors import UserError

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

    def place_block(self, station: int) -> None:
        """What the simulated technician does when asked to move the block."""
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
    """
    if controller not in CONTROLLER_TRANSPORTS:
        raise UserError(f"controller transport {controller!r}: use one of {', '.join(CONTROLLER_TRANSPORTS)}")
    kind = sensor_emulator(sensor)
    plan = parse_faults(faults)
    baud = baudrate or kind.baudrate
    world = World(seed=seed, noise=Noise() if noise else Noise.off())
    block = world.block

    def sensor_value(_output: int = 1) -> float | None:
        d = world.sensor_distance_mm()
        return None if d is None else block.standoff_mm - d  # height sign: closer -> larger

    pty = PtyEndpoint(kind.factory(sensor_value, faults=plan), baudrate=baud, faults=plan, link=sensor_link)
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
