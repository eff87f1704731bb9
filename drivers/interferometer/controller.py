"""Interferometer controller driver (pymodbus sync client, Modbus TCP or RTU).

Trigger handshake (docs/modbus-map.md): read the sequence counter, write
command 1, poll the status block until the counter changes (deadline), then
read the data block 100-127 in one request and check that the counter did not
move meanwhile.  Bounded retries on a missing completion.  Transport, URL
parsing (RTU 8E1 by default) and the mapping of every pymodbus failure to a
typed error live in :mod:`drivers.modbus_link`; after ``ConnectionLost`` the
next call reconnects.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from ..errors import DeviceError, DriverError, ProtocolError, TransportTimeout
from ..modbus_link import MODBUS_EXCEPTION_TEXT, ModbusLink, SerialSettings
from ..readings import ControllerStatus, InterferometerReading
from .codec import check_word_order, decode_block, decode_status
from .register_map import RegisterMap, load_register_map

__all__ = ["MODBUS_EXCEPTION_TEXT", "InterferometerController", "RTU_DEFAULT"]

#: RTU framing when the URL does not say otherwise: 19200 baud, 8E1 (Modbus over serial line spec, 2.5.1).
RTU_DEFAULT = SerialSettings(baudrate=19200, parity="E", stopbits=1)

CHANNELS = ("position_mm", "stry_um", "strz_um", "pitch_urad", "yaw_urad", "roll_urad")
ENVIRONMENT = ("air_temp_c", "air_pressure_hpa", "humidity_pct", "material_temp_c")


class InterferometerController:
    """6-DOF interferometer controller with environment unit, over Modbus TCP or RTU."""

    protocol = "modbus"

    def __init__(
        self,
        link: ModbusLink,
        *,
        word_order: str = "ABCD",
        register_map: RegisterMap | None = None,
        trigger_timeout_s: float = 2.0,
        poll_interval_s: float = 0.002,
        retries: int = 2,
    ) -> None:
        self._link = link
        self.word_order = check_word_order(word_order)
        self.map = register_map or load_register_map()
        self.trigger_timeout_s = trigger_timeout_s
        self.poll_interval_s = poll_interval_s
        self.retries = retries

    @property
    def endpoint(self) -> str:
        return self._link.url

    @property
    def device_id(self) -> int:
        return self._link.device_id

    # -- construction -----------------------------------------------------------------
    @classmethod
    def from_url(
        cls, url: str, *, timeout_s: float = 1.0, device_id: int = 1, word_order: str = "ABCD",
        **kwargs: Any,
    ) -> InterferometerController:
        """Connect to ``modbus-tcp://host:port`` or ``modbus-rtu:PORT[?baud=19200&parity=E&stopbits=1]``.

        RTU defaults to 19200 baud 8E1.  Raises ``ValueError`` for a malformed
        URL and :class:`~drivers.errors.ConnectionLost` if the port or host
        cannot be opened.
        """
        link = ModbusLink(url, timeout_s=timeout_s, device_id=device_id, rtu_default=RTU_DEFAULT,
                          name="controller")
        link.connect()
        return cls(link, word_order=word_order, **kwargs)

    def close(self) -> None:
        self._link.close()

    # -- low level ----------------------------------------------------------------------
    def read_registers(self, address: int, count: int) -> list[int]:
        """Read ``count`` holding registers at ``address`` (map extensions such as the in-position block)."""
        return self._link.read_holding(address, count)

    def write_register(self, address: int, value: int, *, what: str = "") -> None:
        """Write one holding register (map extensions such as the in-position acknowledge)."""
        self._link.write_register(address, value, what=what or f"write register {address}")


    def _write_command(self, name: str) -> None:
        code = self.map.commands[name]
        self._link.write_register(self.map["command"].address, code, what=f"command {name}")

    # -- public API ---------------------------------------------------------------------
    def read_status(self) -> ControllerStatus:
        """Read status word, sequence counter and error code (one request)."""
        start, count = self.map.span("status", "error_code")
        status, seq, err = self.read_registers(start, count)
        return decode_status(status, seq, err, self.map)

    def _wait(self, done: Callable[[ControllerStatus], bool], what: str) -> ControllerStatus:
        deadline = time.monotonic() + self.trigger_timeout_s
        while True:
            st = self.read_status()
            if done(st):
                return st
            if time.monotonic() > deadline:
                raise TransportTimeout(
                    f"controller {self.endpoint}: {what} not completed within {self.trigger_timeout_s} s "
                    f"(sequence {st.sequence}, status 0x{st.raw_status:04x})"
                )
            time.sleep(self.poll_interval_s)

    def _raise_if_error(self, st: ControllerStatus, what: str) -> None:
        if st.error:
            raise DeviceError(st.error_code, st.error_text or "error flag set", command=what)

    def zero(self) -> ControllerStatus:
        """Set the datum at the current pose (all channels read 0 afterwards)."""
        before = self.read_status()
        self._raise_if_error(before, "zero")
        self._write_command("zero")
        st = self._wait(lambda s: s.sequence != before.sequence and not s.busy, "zero")
        self._raise_if_error(st, "zero")
        return st

    def clear_error(self) -> ControllerStatus:
        """Clear a latched error."""
        self._write_command("clear_error")
        return self._wait(lambda s: not s.error and not s.busy, "clear error")

    def _read_consistent(self, st: ControllerStatus) -> InterferometerReading:
        """Read the data block; accept it if the sequence counter did not move meanwhile."""
        start, count = self.map.span("position_mm", "material_temp_c")
        for _ in range(3):
            regs = self.read_registers(start, count)
            after = self.read_status()
            if after.sequence == st.sequence:
                values = decode_block(regs, start, CHANNELS + ENVIRONMENT, self.map, self.word_order)
                return InterferometerReading(**values, sequence=after.sequence, status=after,
                                             timestamp_s=time.time())
            st = after
        raise ProtocolError(f"controller {self.endpoint}: data kept changing during the read")

    def read_data(self) -> InterferometerReading:
        """Read the latest measurement without triggering."""
        return self._read_consistent(self.read_status())

    def trigger_and_read(self) -> InterferometerReading:
        """Trigger one measurement, wait for it and return it.

        A trigger whose completion does not show within ``trigger_timeout_s``
        is retried ``retries`` times (a still-busy controller is waited for,
        not re-triggered); then :class:`TransportTimeout`.  A measurement that
        ends with the error flag raises :class:`DeviceError` with the
        controller's error code and text.
        """
        last_exc: TransportTimeout | None = None
        for _ in range(self.retries + 1):
            try:
                before = self.read_status()
                if before.busy:  # an earlier trigger is still running: let it finish first
                    before = self._wait(lambda s: not s.busy, "previous measurement")
                self._raise_if_error(before, "trigger")
                self._write_command("trigger")
                st = self._wait(lambda s, b=before: s.sequence != b.sequence and not s.busy, "trigger")
            except TransportTimeout as exc:
                last_exc = exc
                continue
            self._raise_if_error(st, "trigger")
            return self._read_consistent(st)
        assert last_exc is not None
        raise last_exc

    def identify(self) -> dict[str, str]:
        """Vendor, model and revision from Modbus 'read device identification' (FC 43/14).

        Asks for the regular object set first (model name), then the basic set;
        an empty dict when the controller does not offer the function.
        """
        names = {0: "vendor", 1: "product_code", 2: "revision", 4: "product", 5: "model"}
        client = self._link.client
        for read_code in (2, 1):
            try:
                rr = self._link.call("read device identification", client.read_device_information,
                                     read_code=read_code)
            except DriverError:  # identification is optional: never fail a run for it
                continue
            info = getattr(rr, "information", {}) or {}
            out = {names[k]: (v.decode("ascii", "replace") if isinstance(v, bytes) else str(v))
                   for k, v in info.items() if k in names}
            if out:
                return out
        return {}

    def read(self) -> dict[str, dict[str, Any]]:
        """Bluesky-style reading of every channel (triggered capture)."""
        r = self.trigger_and_read()
        return {k: {"value": getattr(r, k), "timestamp": r.timestamp_s} for k in CHANNELS + ENVIRONMENT}

    def describe(self) -> dict[str, dict[str, Any]]:
        """Schema of :meth:`read`, with the same keys."""
        return {
            k: {"source": f"modbus:{self.endpoint}:{self.map[k].address}", "dtype": "number",
                "shape": [], "units": self.map[k].unit}
            for k in CHANNELS + ENVIRONMENT
        }
