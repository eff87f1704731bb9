"""XY-MD02 (SHT20) temperature / humidity transmitter over Modbus RTU.

Register map (protocols.md 2.6, public XY-MD02 maps), function code 4 (read
input registers), 0-based addresses:

* 1 - temperature x 10, signed 16-bit, degC (0x00EA = 23.4 degC, 0xFF85 = -12.3 degC)
* 2 - relative humidity x 10, unsigned, %RH (0x01C8 = 45.6 %RH)

Both are read in one request (``01 04 00 01 00 02 20 0B``).  Factory defaults:
device id 1, 9600 baud 8N1; some batches ship 8E1 (``?parity=E``).
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import Any

from ..errors import ProtocolError
from ..modbus_link import ModbusLink, SerialSettings
from ..readings import TempHumidityReading

REG_TEMPERATURE = 1
REG_HUMIDITY = 2
RTU_DEFAULT = SerialSettings(baudrate=9600, parity="N", stopbits=1)
CHANNELS = {"temp_c": "degC", "humidity_pct": "%RH"}


def decode_temp_humidity(registers: Sequence[int]) -> tuple[float, float]:
    """(temperature degC, relative humidity %RH) from input registers 1 and 2."""
    if len(registers) != 2 or any(not 0 <= r <= 0xFFFF for r in registers):
        raise ProtocolError(f"XY-MD02 reply must be two 16-bit registers, got {list(registers)!r}")
    t_raw, rh_raw = registers
    temp = t_raw - 0x10000 if t_raw & 0x8000 else t_raw
    return temp / 10.0, rh_raw / 10.0


class XYMD02:
    """One XY-MD02 transmitter on a Modbus RTU bus (or behind a Modbus TCP gateway)."""

    protocol = "modbus"

    def __init__(self, link: ModbusLink) -> None:
        self._link = link

    @property
    def endpoint(self) -> str:
        return self._link.url

    @classmethod
    def from_url(cls, url: str, *, timeout_s: float = 0.5, device_id: int = 1) -> XYMD02:
        """Open ``modbus-rtu:PORT[?baud=9600&parity=N&stopbits=1]`` (or ``modbus-tcp://HOST:PORT``)."""
        link = ModbusLink(url, timeout_s=timeout_s, device_id=device_id, rtu_default=RTU_DEFAULT,
                          name="XY-MD02 transmitter")
        link.connect()
        return cls(link)

    def close(self) -> None:
        self._link.close()

    def read_once(self) -> TempHumidityReading:
        """One reading (a single FC 04 request for registers 1-2)."""
        temp_c, rh_pct = decode_temp_humidity(self._link.read_input(REG_TEMPERATURE, 2))
        return TempHumidityReading(temp_c=temp_c, humidity_pct=rh_pct, timestamp_s=time.time())

    def read(self) -> dict[str, dict[str, Any]]:
        """Bluesky-style reading: ``temp_c`` and ``humidity_pct``."""
        r = self.read_once()
        return {k: {"value": getattr(r, k), "timestamp": r.timestamp_s} for k in CHANNELS}

    def describe(self) -> dict[str, dict[str, Any]]:
        """Schema of :meth:`read`, with the same keys."""
        regs = {"temp_c": REG_TEMPERATURE, "humidity_pct": REG_HUMIDITY}
        return {k: {"source": f"modbus:{self.endpoint}:ir{regs[k]}", "dtype": "number", "shape": [],
                    "units": unit} for k, unit in CHANNELS.items()}
