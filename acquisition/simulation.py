"""Composition root of a simulated session: the only runtime module that
imports ``mocks``.

It builds one simulated world, puts a Keyence LK-G emulator behind a real
pseudo-terminal and a Modbus TCP interferometer controller on 127.0.0.1 (an
ephemeral port), and returns their endpoints.  Everything downstream opens
those endpoints with the real drivers, exactly as on a real rig.
"""

from __future__ import annotations

from dataclasses import dataclass

from mocks.faults import FaultPlan, FaultSpecError
from mocks.interferometer import InterferometerEmulator, ModbusServerThread, start_controller
from mocks.keyence_lkg import KeyenceLKGEmulator
from mocks.serial_endpoints import PtyEndpoint
from mocks.world import Noise, World
from processing.geometry import BlockGeometry

from .errors import UserError


@dataclass
class SimulatedRig:
    """Running emulators, their endpoints and the world behind them."""

    world: World
    sensor_protocol: str
    sensor_url: str
    controller_url: str
    _pty: PtyEndpoint
    _modbus: ModbusServerThread

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

    def close(self) -> None:
        self._modbus.stop()
        self._pty.stop()


def start_simulated_rig(
    *,
    seed: int = 0,
    noise: bool = True,
    sensor_decimals: int = 5,
    measure_time_s: float = 0.0,
    baudrate: int = 115200,
    faults: str | None = None,
    controller: str = "tcp",
) -> SimulatedRig:
    """Start the emulators on real transports and return their endpoints.

    ``faults`` is a fault-plan spec (see :mod:`mocks.faults`), e.g.
    ``"sensor:garbage@12"``.  ``controller`` is ``"tcp"`` (Modbus TCP on
    127.0.0.1) or ``"rtu"`` (Modbus RTU on a pty pair at ``baudrate``).
    """
    if controller not in ("tcp", "rtu"):
        raise UserError(f"controller transport {controller!r} must be tcp or rtu")
    try:
        plan = FaultPlan.parse(faults)
    except FaultSpecError as exc:
        raise UserError(str(exc)) from exc
    world = World(seed=seed, noise=Noise() if noise else Noise.off())
    block = world.block

    def sensor_value(_output: int) -> float | None:
        d = world.sensor_distance_mm()
        return None if d is None else block.standoff_mm - d  # height sign: closer -> larger

    pty = PtyEndpoint(KeyenceLKGEmulator(sensor_value, decimals=sensor_decimals, faults=plan),
                      baudrate=baudrate)
    try:
        modbus = start_controller(InterferometerEmulator(world, measure_time_s=measure_time_s, faults=plan),
                                  transport=controller, baudrate=baudrate)
    except BaseException:
        pty.stop()
        raise
    return SimulatedRig(world, "keyence-lkg", pty.path, modbus.url, pty, modbus)
