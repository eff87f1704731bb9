"""Composition root of a simulated session: the only runtime module that
imports ``mocks``.

It builds one simulated world, puts a Keyence LK-G emulator behind a real
pseudo-terminal and a Modbus TCP interferometer controller on 127.0.0.1 (an
ephemeral port), and returns their endpoints.  Everything downstream opens
those endpoints with the real drivers, exactly as on a real rig.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from mocks.faults import FaultPlan, FaultSpecError
from mocks.interferometer import InterferometerEmulator, ModbusServerThread
from mocks.keyence_lkg import KeyenceLKGEmulator
from mocks.serial_endpoints import PtyEndpoint
from mocks.world import BlockSetup, Noise, World
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

    def place_block(self, station: int, **_: Any) -> None:
        """What the simulated technician does when asked to move the block (any pass)."""
        self.world.place_block(station)

    def close(self) -> None:
        self._modbus.stop()
        self._pty.stop()


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
    sensor_decimals: int = 5,
    measure_time_s: float = 0.0,
    baudrate: int = 115200,
    faults: str | None = None,
    block_length_mm: float | None = None,
    geometry: BlockGeometry | None = None,
    wire_time: bool = True,
) -> SimulatedRig:
    """Start the emulators on real transports and return their endpoints.

    ``faults`` is a fault-plan spec (see :mod:`mocks.faults`), e.g.
    ``"sensor:garbage@12"``.  ``block_length_mm`` and ``geometry`` build the
    simulated block to match a set-up file (default: :func:`default_block`).
    ``wire_time=False``: the sensor answers without the serial line's transfer
    time (zero-latency emulators, for benchmarks).
    """
    try:
        plan = FaultPlan.parse(faults)
    except FaultSpecError as exc:
        raise UserError(str(exc)) from exc
    sign = 1.0
    block = None
    if block_length_mm is not None or geometry is not None:
        d_len, d_geo = default_block()
        geometry = geometry or d_geo
        block = _block_for(block_length_mm or d_len, geometry)
        sign = 1.0 if geometry.sensor_sign == "height" else -1.0
    world = World(seed=seed, noise=Noise() if noise else Noise.off(), block=block)
    block = world.block

    def sensor_value(_output: int) -> float | None:
        d = world.sensor_distance_mm()
        # height sign: the surface closer -> larger; gap sign: the opposite
        return None if d is None else sign * (block.standoff_mm - d)

    pty = PtyEndpoint(KeyenceLKGEmulator(sensor_value, decimals=sensor_decimals, faults=plan),
                      baudrate=baudrate if wire_time else 0)
    try:
        modbus = ModbusServerThread(
            InterferometerEmulator(world, measure_time_s=measure_time_s, faults=plan).device()
        )
    except BaseException:
        pty.stop()
        raise
    return SimulatedRig(world, "keyence-lkg", pty.path, modbus.url, pty, modbus)
