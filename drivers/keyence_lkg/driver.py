"""Keyence LK-G3000/LK-G5000 driver over any :class:`~drivers.transport.ByteLink`."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import TypeVar

from ..exchange import RequestReply
from ..readings import DisplacementReading, MeasurementStatus
from ..sensor import DisplacementSensor
from ..transport import ByteLink, open_serial
from . import protocol

T = TypeVar("T")
SERIES = ("LK-G3000", "LK-G5000")


def check_output(series: str, output: int) -> None:
    """ValueError unless ``series`` is an LK-G series and ``output`` one of its outputs
    (LK-G3000: OUT1/OUT2 via ``M1``/``M2``; LK-G5000: OUT 1..99 via ``MS,<nn>``)."""
    if series not in SERIES:
        raise ValueError(f"LK-G series must be one of {', '.join(SERIES)}, not {series!r}")
    high = 2 if series == "LK-G3000" else protocol.MAX_MS_OUTPUT
    if isinstance(output, bool) or not isinstance(output, int) or not 1 <= output <= high:
        raise ValueError(f"{series} output must be 1..{high}, not {output!r}")


class KeyenceLKG(DisplacementSensor):
    """LK-G controller; values in mm with the controller's sign.

    ``series="LK-G3000"`` polls ``M1``/``M2``; ``series="LK-G5000"`` polls
    ``MS,<nn>`` (OUT 1..99).  Settings commands (``SW``) need set-up mode;
    :meth:`set_offset` and :meth:`set_head_mode` switch to it (``Q0``) and
    always return to measure mode (``R0``).
    """

    protocol = "keyence-lkg"

    def __init__(
        self,
        link: ByteLink,
        *,
        output: int = 1,
        series: str = "LK-G3000",
        endpoint: str = "",
        timeout_s: float = 0.5,
    ) -> None:
        super().__init__(link, endpoint=endpoint, timeout_s=timeout_s)
        check_output(series, output)
        self.output = output
        self.series = series
        self._line = RequestReply(link, protocol.TERMINATOR)

    @classmethod
    def from_url(
        cls, url: str, *, baudrate: int = 115200, output: int = 1, series: str = "LK-G3000"
    ) -> KeyenceLKG:
        """Open ``url`` (any pyserial URL) at 8N1 and return a driver."""
        return cls(open_serial(url, baudrate=baudrate), output=output, series=series, endpoint=url)

    def _ask(self, request: bytes, decode: Callable[[bytes], T]) -> tuple[T, bytes]:
        return self._line.transact(request, self.timeout_s, decode)

    @staticmethod
    def _reading(value: float, status: MeasurementStatus, frame: bytes) -> DisplacementReading:
        return DisplacementReading(value_mm=value, status=status, timestamp_s=time.time(),
                                   raw=frame.decode("ascii"))

    def read_once(self) -> DisplacementReading:
        """Measure the configured output once (mm)."""
        if self.series == "LK-G5000":
            (value, status), frame = self._ask(
                protocol.encode_measure_ms(self.output),
                lambda f: protocol.decode_measure_ms(f, self.output),
            )
        else:
            ((value, status),), frame = self._ask(
                protocol.encode_measure(self.output), lambda f: protocol.decode_measure(f, self.output)
            )
        return self._reading(value, status, frame)

    def read_both(self) -> tuple[DisplacementReading, DisplacementReading]:
        """Measure OUT1 and OUT2 in one ``M0`` exchange (mm)."""
        ((v1, s1), (v2, s2)), frame = self._ask(protocol.encode_measure(0),
                                                  lambda f: protocol.decode_measure(f, 0))
        return self._reading(v1, s1, frame), self._reading(v2, s2, frame)

    def enter_setup_mode(self) -> None:
        """``Q0``: set-up (communication) mode; the controller stops measuring."""
        self._ask(protocol.encode_setup_mode(), lambda f: protocol.decode_ack(f, "Q0"))

    def enter_measure_mode(self) -> None:
        """``R0``: back to measure (general) mode."""
        self._ask(protocol.encode_measure_mode(), lambda f: protocol.decode_ack(f, "R0"))

    def reset(self, output: int = 0) -> None:
        """``VR``: reset OUT1, OUT2 or both (``output=0``)."""
        self._ask(protocol.encode_reset(output), lambda f: protocol.decode_ack(f, "VR"))

    def offset(self, output: int | None = None) -> float:
        """Get the offset of an output (default: the polled one), in mm."""
        out = self.output if output is None else output
        (value, _decimals), _ = self._ask(protocol.encode_read_offset(out),
                                          lambda f: protocol.decode_read_offset(f, out))
        return value

    def set_offset(self, value_mm: float, output: int | None = None) -> None:
        """Set the offset of an output (default: the polled one), in mm.

        The setting is written without a decimal point in units of the last
        displayed digit, so the current offset is read first (``SR,OF``) to
        learn the decimal position; then ``Q0``, ``SW,OF``, ``R0``.
        """
        out = self.output if output is None else output
        (_, decimals), _ = self._ask(protocol.encode_read_offset(out),
                                     lambda f: protocol.decode_read_offset(f, out))
        counts = round(value_mm * 10**decimals)
        request = protocol.encode_write_offset(out, counts)  # ValueError before any mode change
        self._in_setup_mode(lambda: self._ask(request, lambda f: protocol.decode_ack(f, "SW,OF")))

    def head_mode(self, head: int) -> int:
        """Get the measurement-mode function number of a head (1 or 2)."""
        fn, _ = self._ask(protocol.encode_read_head_mode(head), lambda f: protocol.decode_read_head_mode(f, head))
        return fn

    def set_head_mode(self, head: int, function: int) -> None:
        """Set the measurement-mode function number of a head (``Q0``, ``SW,HB``, ``R0``)."""
        request = protocol.encode_write_head_mode(head, function)
        self._in_setup_mode(lambda: self._ask(request, lambda f: protocol.decode_ack(f, "SW,HB")))

    def _in_setup_mode(self, action: Callable[[], object]) -> None:
        self.enter_setup_mode()
        try:
            action()
        finally:
            self.enter_measure_mode()

    def identify(self) -> dict[str, str]:
        """The LK-G command set has no identity query; report the family only."""
        return {"model": f"Keyence {self.series} (RS-232C)"}
