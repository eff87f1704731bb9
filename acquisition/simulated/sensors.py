"""The simulated displacement sensors: one emulator per sensor family (:data:`SENSOR_EMULATORS`,
keyed by the protocol names of :data:`acquisition.rig.SENSOR_PROTOCOLS`), the value each reports
for a surface height, and the simulated gauge block a set-up's geometry describes."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from typing import Any, Protocol

from mocks.keyence_lkg import KeyenceLKGEmulator
from mocks.me_ild1420 import ILD1420Emulator, StreamPacer
from mocks.panasonic_hlg1 import PanasonicHLG1Emulator
from mocks.serial_endpoints import ByteEmulator
from mocks.world import BlockSetup
from processing.geometry import BlockGeometry, SensorSign
from saved_runs.errors import UserError

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


def sensor_emulator(protocol: str) -> SensorEmulator:
    """The registered emulator of a sensor protocol; a :class:`UserError` naming the choices."""
    try:
        return SENSOR_EMULATORS[protocol]
    except KeyError:
        raise UserError(
            f"no simulated sensor {protocol!r}; use one of: {', '.join(SENSOR_EMULATORS)}"
        ) from None


# Sensor requests per averaged sample in a run: the LK-G and HL-G1 drivers poll one value per
# command line; the ILD1420 streams its values (no request; its commands are sent at open only).
# tests/acquisition/test_fault_plans.py counts them on the simulated devices.
REQUESTS_PER_SAMPLE = {"keyence-lkg": 1, "panasonic-hlg1": 1, "me-ild1420": 0}


def geometry_of(b: BlockSetup, sign: SensorSign) -> BlockGeometry:
    """Nominal set-up geometry of a simulated block: mirror at P, sensor point Q at the stand-off."""
    q = tuple(b.sensor_head_mm[i] + b.standoff_mm * b.beam[i] for i in range(3))
    return BlockGeometry(mirror_mm=b.mirror_mm, sensor_mm=q, sensor_beam=b.beam,  # type: ignore[arg-type]
                         sensor_sign=sign)


def default_block(sensor: str = "keyence-lkg") -> tuple[float, BlockGeometry]:
    """Block length (mm) and set-up geometry of the default simulated rig with a ``sensor`` head.

    The geometry's ``sensor_sign`` is the one the family's simulated values have.
    """
    b = BlockSetup()
    return b.length_mm, geometry_of(b, sensor_emulator(sensor).sensor_sign)


def block_for(length_mm: float, geometry: BlockGeometry) -> BlockSetup:
    """A simulated block built to match a set-up: mirror at P, sensor reading 0 at Q."""
    standoff = BlockSetup().standoff_mm
    head = tuple(geometry.sensor_mm[i] - standoff * geometry.sensor_beam[i] for i in range(3))
    return BlockSetup(length_mm=length_mm, mirror_mm=geometry.mirror_mm, sensor_head_mm=head,  # type: ignore[arg-type]
                      beam=geometry.sensor_beam, standoff_mm=standoff)
