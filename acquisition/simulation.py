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
from mocks.machine_axis import AxisErrors, InPositionRegisters, MachineAxis, MachineStop
from mocks.serial_endpoints import PtyEndpoint
from mocks.world import BlockSetup, Noise, World
from processing.geometry import BlockGeometry

from .errors import UserError
from .positioning_setup import PositioningSetup, SimulatedAxisSetup


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
    try:
        plan = FaultPlan.parse(faults)
    except FaultSpecError as exc:
        raise UserError(str(exc)) from exc
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
