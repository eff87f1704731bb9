"""Interferometer controller driver (pymodbus sync client, TCP or RTU).

Trigger handshake (docs/modbus-map.md): read the sequence counter, write
command 1, poll the status block until the counter changes (deadline), then
read the data block 100-127 in one request and check that the counter did not
move meanwhile.  Bounded retries on a missing completion.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any
from urllib.parse import parse_qs, urlsplit

from pymodbus import FramerType, ModbusException
from pymodbus.client import ModbusSerialClient, ModbusTcpClient
from pymodbus.exceptions import ConnectionException, ModbusIOException

from ..errors import ConnectionLost, DeviceError, ProtocolError, TransportTimeout
from ..readings import ControllerStatus, InterferometerReading
from .codec import check_word_order, decode_block, decode_status
from .register_map import RegisterMap, load_register_map

MODBUS_EXCEPTION_TEXT = {
    1: "illegal function",
    2: "illegal data address",
    3: "illegal data value",
    4: "server device failure",
    5: "acknowledge",
    6: "server device busy",
    8: "memory parity error",
    10: "gateway path unavailable",
    11: "gateway target device failed to respond",
}

CHANNELS = ("position_mm", "stry_um", "strz_um", "pitch_urad", "yaw_urad", "roll_urad")
ENVIRONMENT = ("air_temp_c", "air_pressure_hpa", "humidity_pct", "material_temp_c")


class InterferometerController:
    """6-DOF interferometer controller with environment unit, over Modbus."""

    protocol = "modbus"

    def __init__(
        self,
        client: ModbusTcpClient | ModbusSerialClient,
        *,
        device_id: int = 1,
        word_order: str = "ABCD",
        register_map: RegisterMap | None = None,
        endpoint: str = "",
        trigger_timeout_s: float = 2.0,
        poll_interval_s: float = 0.002,
        retries: int = 2,
    ) -> None:
        self._client = client
        self.device_id = device_id
        self.word_order = check_word_order(word_order)
        self.map = register_map or load_register_map()
        self.endpoint = endpoint
        self.trigger_timeout_s = trigger_timeout_s
        self.poll_interval_s = poll_interval_s
        self.retries = retries

    # -- construction -----------------------------------------------------------------
    @classmethod
    def from_url(
        cls, url: str, *, timeout_s: float = 1.0, device_id: int = 1, word_order: str = "ABCD",
        **kwargs: Any,
    ) -> InterferometerController:
        """Connect to ``modbus-tcp://host:port`` or ``modbus-rtu:PORT[?baud=..&parity=E]``."""
        client = make_client(url, timeout_s=timeout_s)
        try:
            ok = client.connect()
        except (ModbusException, OSError) as exc:
            raise ConnectionLost(f"cannot connect to controller at {url}: {exc}") from exc
        if not ok:
            client.close()
            raise ConnectionLost(f"cannot connect to controller at {url}: connection refused or port missing")
        return cls(client, device_id=device_id, word_order=word_order, endpoint=url, **kwargs)

    def close(self) -> None:
        self._client.close()

    # -- low level ----------------------------------------------------------------------
    def _call(self, what: str, fn: Callable[..., Any], *args: Any, **kwargs: Any) -> Any:
        try:
            rr = fn(*args, device_id=self.device_id, **kwargs)
        except ConnectionException as exc:
            raise ConnectionLost(f"controller {self.endpoint}: {what}: connection lost ({exc})") from exc
        except ModbusIOException as exc:
            raise TransportTimeout(f"controller {self.endpoint}: {what}: no response") from exc
        except ModbusException as exc:
            raise ProtocolError(f"controller {self.endpoint}: {what}: {exc}") from exc
        except OSError as exc:
            raise ConnectionLost(f"controller {self.endpoint}: {what}: {exc}") from exc
        if rr is None:
            raise TransportTimeout(f"controller {self.endpoint}: {what}: no response")
        if rr.isError():
            code = int(getattr(rr, "exception_code", 0))
            raise DeviceError(
                code, f"Modbus exception: {MODBUS_EXCEPTION_TEXT.get(code, 'unknown')}", command=what
            )
        return rr

    def _read(self, address: int, count: int) -> list[int]:
        rr = self._call(f"read {count} registers at {address}", self._client.read_holding_registers,
                        address, count=count)
        regs = list(rr.registers)
        if len(regs) != count:
            raise ProtocolError(f"controller returned {len(regs)} registers, asked for {count}")
        return regs

    def _write_command(self, name: str) -> None:
        code = self.map.commands[name]
        self._call(f"command {name}", self._client.write_register, self.map["command"].address, code)

    # -- public API ---------------------------------------------------------------------
    def read_status(self) -> ControllerStatus:
        """Read status word, sequence counter and error code (one request)."""
        start, count = self.map.span("status", "error_code")
        status, seq, err = self._read(start, count)
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
        self._write_command("zero")
        st = self._wait(lambda s: s.sequence != before.sequence and not s.busy, "zero")
        self._raise_if_error(st, "zero")
        return st

    def clear_error(self) -> ControllerStatus:
        """Clear a latched error."""
        self._write_command("clear_error")
        return self._wait(lambda s: not s.error and not s.busy, "clear error")

    def read_data(self) -> InterferometerReading:
        """Read the latest measurement without triggering."""
        start, count = self.map.span("position_mm", "material_temp_c")
        for _ in range(3):
            st = self.read_status()
            regs = self._read(start, count)
            after = self.read_status()
            if after.sequence == st.sequence:
                break
        else:
            raise ProtocolError(f"controller {self.endpoint}: data kept changing during the read")
        values = decode_block(regs, start, CHANNELS + ENVIRONMENT, self.map, self.word_order)
        return InterferometerReading(**values, sequence=after.sequence, status=after, timestamp_s=time.time())

    def trigger_and_read(self) -> InterferometerReading:
        """Trigger one measurement, wait for it and return it (bounded retries)."""
        last_exc: TransportTimeout | None = None
        for _ in range(self.retries + 1):
            before = self.read_status()
            self._raise_if_error(before, "trigger")
            self._write_command("trigger")
            try:
                st = self._wait(lambda s, b=before: s.sequence != b.sequence and not s.busy, "trigger")
            except TransportTimeout as exc:
                last_exc = exc
                continue
            self._raise_if_error(st, "trigger")
            return self.read_data()
        assert last_exc is not None
        raise last_exc

    def identify(self) -> dict[str, str]:
        """Vendor, model and revision from Modbus 'read device identification' (FC 43/14).

        Asks for the regular object set first (model name), then the basic set;
        an empty dict when the controller does not offer the function.
        """
        names = {0: "vendor", 1: "product_code", 2: "revision", 4: "product", 5: "model"}
        for read_code in (2, 1):
            try:
                rr = self._client.read_device_information(read_code=read_code, device_id=self.device_id)
            except (ModbusException, OSError):
                continue
            if rr is None or rr.isError():
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


def make_client(url: str, *, timeout_s: float = 1.0) -> ModbusTcpClient | ModbusSerialClient:
    """Build (not connect) a pymodbus client for a controller URL.

    ``modbus-tcp://host:port`` - Modbus TCP.
    ``modbus-rtu:PORT?baud=19200&parity=E&stopbits=1`` - RTU on a serial port
    (any pyserial URL, 8E1 by default as the Modbus specification requires).
    """
    if url.startswith("modbus-tcp://"):
        parts = urlsplit(url)
        if not parts.hostname:
            raise ValueError(f"controller URL {url!r} has no host")
        return ModbusTcpClient(parts.hostname, port=parts.port or 502, timeout=timeout_s, retries=0)
    if url.startswith("modbus-rtu:"):
        rest = url.removeprefix("modbus-rtu:")
        port, _, query = rest.partition("?")
        opts = {k: v[-1] for k, v in parse_qs(query).items()}
        return ModbusSerialClient(
            port,
            framer=FramerType.RTU,
            baudrate=int(opts.get("baud", 19200)),
            parity=opts.get("parity", "E"),
            stopbits=int(opts.get("stopbits", 1)),
            bytesize=8,
            timeout=timeout_s,
            retries=0,
        )
    raise ValueError(
        f"controller URL {url!r} must start with modbus-tcp:// or modbus-rtu: (e.g. modbus-tcp://192.168.0.10:502)"
    )
