"""Panasonic HL-G1 driver over any :class:`~drivers.transport.ByteLink`."""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import TypeVar

from ..exchange import RequestReply
from ..readings import DisplacementReading, MeasurementStatus
from ..sensor import DisplacementSensor
from ..transport import ByteLink, open_serial
from . import protocol as p

T = TypeVar("T")


class PanasonicHLG1(DisplacementSensor):
    """HL-G1 head at RS-485 station ``station`` (1..16); values in mm, the head's sign.

    :meth:`read_once` polls ``RMB`` so that one exchange gives the value *and*
    the ALARM flag (the manual defines no sentinel value for an alarm in
    ``RMD``); :meth:`read_value` polls ``RMD`` alone.  Requests carry a real
    BCC unless ``use_bcc`` is false (``**``); replies must then carry one too.
    """

    protocol = "panasonic-hlg1"

    def __init__(
        self,
        link: ByteLink,
        *,
        station: int = 1,
        use_bcc: bool = True,
        endpoint: str = "",
        timeout_s: float = 0.5,
    ) -> None:
        super().__init__(link, endpoint=endpoint, timeout_s=timeout_s)
        if station not in p.STATIONS:
            raise ValueError(f"HL-G1 station number must be 1..16, not {station}")
        self.station = station
        self.use_bcc = use_bcc
        self._line = RequestReply(link, p.TERMINATOR)

    @classmethod
    def from_url(
        cls, url: str, *, baudrate: int = 115200, station: int = 1, use_bcc: bool = True
    ) -> PanasonicHLG1:
        """Open ``url`` (any pyserial URL) at 8N1 and return a driver."""
        return cls(open_serial(url, baudrate=baudrate), station=station, use_bcc=use_bcc, endpoint=url)

    def _ask(self, command: str, data: str, decode: Callable[[bytes], T]) -> tuple[T, bytes]:
        request = p.encode_request(self.station, command, data, use_bcc=self.use_bcc)
        return self._line.transact(request, self.timeout_s, decode)

    def _read(self, command: str, decode: Callable[..., T]) -> tuple[T, bytes]:
        return self._ask(command, "", lambda f: decode(f, self.station, require_bcc=self.use_bcc))

    def _write(self, command: str, data: str) -> None:
        self._ask(command, data, lambda f: p.decode_ack(f, self.station, command, require_bcc=self.use_bcc))

    def _flag(self, command: str) -> bool:
        value, _ = self._ask(
            command, "", lambda f: p.decode_flag(f, self.station, command, require_bcc=self.use_bcc)
        )
        return value

    def read_once(self) -> DisplacementReading:
        """Measure the displacement once (``RMB``), in mm; ALARM status if the head flags it."""
        outputs, frame = self._read(p.READ_ALL, p.decode_all_outputs)
        if outputs.alarm:
            value, status = math.nan, MeasurementStatus.ALARM
        else:
            value, status = outputs.value_mm, MeasurementStatus.OK
        return DisplacementReading(value_mm=value, status=status, timestamp_s=time.time(),
                                   raw=frame.decode("ascii"))

    def read_value(self) -> DisplacementReading:
        """Measure the displacement once with ``RMD`` (mm; no alarm information)."""
        value, frame = self._read(p.READ_MEASURED, p.decode_measured)
        return DisplacementReading(value_mm=value, status=MeasurementStatus.OK, timestamp_s=time.time(),
                                   raw=frame.decode("ascii"))

    def read_all_outputs(self) -> p.AllOutputs:
        """Get value (mm), light intensity and OUT1..3 / ALARM states in one ``RMB`` exchange."""
        outputs, _ = self._read(p.READ_ALL, p.decode_all_outputs)
        return outputs

    def light_intensity(self) -> int:
        """Measure the received light intensity (``RID``, 0..4095)."""
        value, _ = self._ask(
            p.READ_LIGHT, "", lambda f: p.decode_setting(f, self.station, p.READ_LIGHT, require_bcc=self.use_bcc)
        )
        return value

    def alarm(self) -> bool:
        """Get the alarm output state (``ROA``)."""
        return self._flag(p.READ_ALARM)

    def judgement_output(self, number: int) -> bool:
        """Get the state of judgement output OUT1, OUT2 or OUT3 (``RZA``/``RZB``/``RZC``)."""
        if number not in (1, 2, 3):
            raise ValueError(f"HL-G1 judgement output must be 1, 2 or 3, not {number}")
        return self._flag(p.READ_OUTPUTS[number - 1])

    def sampling_cycle_code(self) -> int:
        """Get the sampling-cycle setting code (``RSP``; the manual's example: 1 = 500 us)."""
        value, _ = self._ask(
            p.READ_SAMPLING, "",
            lambda f: p.decode_setting(f, self.station, p.READ_SAMPLING, require_bcc=self.use_bcc),
        )
        return value

    def zero_set(self, on: bool = True) -> None:
        """Zero set on (``WZS +00001``: the current value becomes 0) or off (``+00000``)."""
        self._write(p.ZERO_SET, p.format_setting(1 if on else 0))

    def reset(self) -> None:
        """Reset input (``WRS +00001``)."""
        self._write(p.RESET, p.format_setting(1))

    def laser(self, on: bool) -> None:
        """Switch the laser emission on or off (``WLR``)."""
        self._write(p.LASER, p.format_setting(1 if on else 0))

    def set_averaging_code(self, code: int) -> None:
        """Set the averaging setting code (``WAV``; code meanings are in the manual's table)."""
        if not 0 <= code <= 99_999:
            raise ValueError(f"HL-G1 averaging code must be 0..99999, not {code}")
        self._write(p.AVERAGING, p.format_setting(code))

    def set_threshold_a(self, value_mm: float) -> None:
        """Set judgement threshold A in mm (``WHA``, 0.0001 mm resolution)."""
        self._write(p.THRESHOLD_A, p.format_measured(value_mm))

    def identify(self) -> dict[str, str]:
        """The HL-G1 command set has no identity query; report the family and station."""
        return {"model": "Panasonic HL-G1 (RS-485)", "station": f"{self.station:02d}"}
