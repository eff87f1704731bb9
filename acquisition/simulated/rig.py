"""The simulated straightness rig: one simulated world, a displacement-sensor emulator behind a real
pseudo-terminal and a Modbus interferometer controller on 127.0.0.1 (TCP, RTU on a pty, or RTU
framing over TCP), returned as their endpoints; and the XY-MD02 transmitter of either run kind.
Everything downstream opens those endpoints with the real drivers, exactly as on a real rig.
"""

from __future__ import annotations

import contextlib
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from pymodbus import FramerType

from mocks.effects import SensorEffects
from mocks.faults import FaultPlan
from mocks.interferometer import InterferometerEmulator, ModbusServerThread, start_controller
from mocks.machine_axis import MachineAxis
from mocks.serial_endpoints import PtyEndpoint
from mocks.world import BlockSetup, Noise, World
from mocks.xymd02 import XYMD02Emulator, start_xymd02, world_source
from processing.geometry import BlockGeometry, SensorSign
from saved_runs.errors import UserError

from .effects import scenario_world
from .faults import parse_faults
from .sensors import Stream, block_for, default_block, geometry_of, sensor_emulator

if TYPE_CHECKING:
    from .scenario import Scenario


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
        return geometry_of(self.world.block, self.sensor_sign)

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
        block = block_for(block_length_mm or d_len, geometry)
        # the head is set up (mounted, or its output inverted) to read with the set-up's sign
        sensor_sign = geometry.sensor_sign
    flip = 1.0 if sensor_sign == kind.sensor_sign else -1.0
    sensor_fx, started = SensorEffects(), time.monotonic()
    if scenario is not None:
        world, sensor_fx = scenario_world(scenario, block or BlockSetup(), seed, noise)
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
