"""Interferometer controller driver (pymodbus sync client, Modbus TCP or RTU).

Trigger handshake (docs/modbus-map.md): read the sequence counter, write
command 1, poll the status block until the counter changes (deadline), then
read the data block 100-127 in one request and check that the counter did not
move meanwhile.  Bounded retries on a missing completion: a measurement still
running at the deadline is waited for (never re-triggered, so one that
completes late is used); only a trigger the controller did not take is
sent again.  Transport, URL
parsing (RTU 8E1 by default) and the mapping of every pymodbus failure to a
typed error live in :mod:`drivers.modbus_link`; after ``ConnectionLost`` the
next call reconnects.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from ..errors import CompletionTimeout, DeviceError, DriverError, ProtocolError, TransportTimeout, with_context
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
        cls, url: str, *, timeout_s: float = 1.0, device_id: int | None = None, word_order: str = "ABCD",
        **kwargs: Any,
    ) -> InterferometerController:
        """Connect to ``modbus-tcp://host:port[?device_id=N]`` or
        ``modbus-rtu:PORT[?baud=19200&parity=E&stopbits=1&device_id=N]``.

        RTU defaults to 19200 baud 8E1, the device id to 1.  ``timeout_s`` is the
        timeout of one Modbus request; ``kwargs`` are the trigger settings of the
        constructor.  Raises ``ValueError`` for a malformed URL and
        :class:`~drivers.errors.ConnectionLost` if the port or host cannot be opened.
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

    def _wait(self, done: Callable[[ControllerStatus], bool], what: str, *,
              raise_on_timeout: bool = True) -> ControllerStatus:
        """Poll the status block until ``done`` (deadline ``trigger_timeout_s``).

        A poll whose reply is lost is polled again.  At the deadline: the
        controller answered but ``done`` never held -> :class:`CompletionTimeout`
        (its ``status`` is the last status seen), or the last status when
        ``raise_on_timeout`` is False; the last poll went unanswered -> that
        :class:`TransportTimeout`.
        """
        deadline = time.monotonic() + self.trigger_timeout_s
        st: ControllerStatus | None = None
        while True:
            lost: TransportTimeout | None = None
            try:
                st = self.read_status()
            except TransportTimeout as exc:
                lost = exc
            else:
                if done(st):
                    return st
            if time.monotonic() > deadline:
                if lost is not None or st is None:
                    raise lost or TransportTimeout(f"controller {self.endpoint}: {what}: no status")
                if not raise_on_timeout:
                    return st
                raise CompletionTimeout(
                    f"controller {self.endpoint}: {what} not completed within {self.trigger_timeout_s:g} s "
                    f"(sequence {st.sequence}, status 0x{st.raw_status:04x}{', busy' if st.busy else ''}): "
                    "the controller answers but did not finish; a slow controller needs a longer trigger timeout",
                    status=st)
            time.sleep(self.poll_interval_s)

    def _raise_if_error(self, st: ControllerStatus, what: str) -> None:
        if st.error:
            raise with_context(DeviceError(st.error_code, st.error_text or "error flag set", command=what),
                               f"controller {self.endpoint}")

    def zero(self) -> ControllerStatus:
        """Set the datum at the current pose (all channels read 0 afterwards); waited for like a
        trigger (:meth:`trigger_and_read`)."""
        return self._run_command("zero")

    def clear_error(self) -> ControllerStatus:
        """Clear a latched error (command 5) and return the status afterwards.

        The caller checks it: a cause that persists (the beam still interrupted) keeps
        the error flag set or the *beam OK* bit clear.
        """
        self._write_command("clear_error")
        return self._wait(lambda s: not s.busy, "clear error", raise_on_timeout=False)

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

    def _start(self, command: str, sequence: int) -> None:
        """Write the command; if its reply is lost, write it again only when the controller shows
        it did not take it (neither busy nor a new sequence number)."""
        try:
            self._write_command(command)
        except TransportTimeout:
            st = self.read_status()
            if not (st.busy or st.sequence != sequence):
                self._write_command(command)

    def _run_command(self, command: str) -> ControllerStatus:
        """Trigger or zero: start the measurement and wait for its completion (see :meth:`trigger_and_read`)."""
        before = self.read_status()
        if before.busy:  # an earlier trigger is still running: let it finish first
            before = self._wait(lambda s: not s.busy, "previous measurement")
        self._raise_if_error(before, command)
        seq = before.sequence
        self._start(command, seq)
        for attempt in range(self.retries + 1):
            try:
                st = self._wait(lambda s: (s.sequence != seq or s.error) and not s.busy, command)
            except CompletionTimeout as exc:
                if attempt == self.retries:
                    raise
                if not (isinstance(exc.status, ControllerStatus) and exc.status.busy):  # the command was not taken
                    self._start(command, seq)
                continue
            self._raise_if_error(st, command)
            return st
        raise AssertionError("unreachable")  # pragma: no cover

    def trigger_and_read(self) -> InterferometerReading:
        """Trigger one measurement, wait for it and return it.

        A completion that does not show within ``trigger_timeout_s`` is waited
        for again, up to ``retries`` times: while the controller still reports
        *busy* the running measurement is kept (a slow controller's late result
        is used, not discarded); a trigger it never took is sent again.  Then
        :class:`~drivers.errors.CompletionTimeout`.  A still-busy controller
        (an earlier trigger) is waited for first.  A measurement that ends with
        the error flag raises :class:`DeviceError` with the controller's error
        code and text (the error stays latched until :meth:`clear_error`).
        """
        return self._read_consistent(self._run_command("trigger"))

    def identify(self) -> dict[str, str]:
        """Vendor, product code, revision, product and model from Modbus 'read device
        identification' (FC 43/14), asked with the basic and the regular read codes and merged.

        A device may answer the regular code with the regular objects only (product, model)
        or refuse it; either way the basic objects come from the basic code.  An empty dict
        when the controller offers neither.
        """
        names = {0: "vendor", 1: "product_code", 2: "revision", 4: "product", 5: "model"}
        client = self._link.client
        objects: dict[int, str] = {}
        for read_code in (1, 2):
            try:
                rr = self._link.call("read device identification", client.read_device_information,
                                     read_code=read_code)
            except DriverError:  # identification is optional: never fail a run for it
                continue
            for k, v in (getattr(rr, "information", {}) or {}).items():
                text = v.decode("ascii", "replace") if isinstance(v, bytes) else str(v)
                if k in names and text:
                    objects.setdefault(k, text)
        return {names[k]: objects[k] for k in sorted(objects)}

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
