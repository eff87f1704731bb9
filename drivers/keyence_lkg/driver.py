"""Keyence LK-G3000/LK-G5000 driver over any :class:`~drivers.transport.ByteLink`."""

from __future__ import annotations

import time

from ..readings import DisplacementReading
from ..sensor import DisplacementSensor
from ..transport import ByteLink, open_serial
from . import protocol


class KeyenceLKG(DisplacementSensor):
    """LK-G controller; polls ``M<output>`` (values in mm, controller's sign)."""

    protocol = "keyence-lkg"

    def __init__(
        self,
        link: ByteLink,
        *,
        output: int = 1,
        endpoint: str = "",
        timeout_s: float = 0.5,
    ) -> None:
        super().__init__(link, endpoint=endpoint, timeout_s=timeout_s)
        if output not in (1, 2):
            raise ValueError("LK-G output must be 1 or 2")
        self.output = output

    @classmethod
    def from_url(cls, url: str, *, baudrate: int = 115200, output: int = 1) -> KeyenceLKG:
        """Open ``url`` (any pyserial URL) at 8N1 and return a driver."""
        return cls(open_serial(url, baudrate=baudrate), output=output, endpoint=url)

    def _transact(self, request: bytes) -> bytes:
        self._link.write(request)
        return self._link.read_until(protocol.TERMINATOR, self.timeout_s)

    def read_once(self) -> DisplacementReading:
        """Measure OUT<output> once (mm)."""
        frame = self._transact(protocol.encode_measure(self.output))
        ((value, status),) = protocol.decode_measure(frame, self.output)
        return DisplacementReading(
            value_mm=value, status=status, timestamp_s=time.time(), raw=frame.decode("ascii")
        )

    def identify(self) -> dict[str, str]:
        """The LK-G command set has no identity query; report the family only."""
        return {"model": "Keyence LK-G (RS-232C)"}
