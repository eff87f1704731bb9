"""A pymodbus 3.16 sync client behind a small interface that only ever raises
the typed errors of :mod:`drivers.errors`.

pymodbus reports failures in two ways (design.md 5.2): a library or transport
failure *raises* (``ConnectionException``, ``ModbusIOException``), a Modbus
exception reply from the device is *returned* (``isError()``).  Both end up
here as one of:

* :class:`ConnectionLost` - the connection could not be (re)opened or was closed
  by the peer.  The next call reconnects (pymodbus's sync clients reconnect on
  every request while disconnected), so a caller may simply retry.
* :class:`TransportTimeout` - nothing arrived within the timeout.
* :class:`ChecksumError` - an RTU frame arrived whose CRC does not match
  (pymodbus drops such frames silently and times out; the bytes it saw are
  kept by a ``trace_packet`` hook so the cause is not lost).
* :class:`ProtocolError` - bytes arrived but no valid reply could be decoded.
* :class:`DeviceError` - a Modbus exception response; ``code`` is the exception
  code, ``text`` its meaning from the Modbus application protocol (section 7).

URLs:

* ``modbus-tcp://HOST[:PORT]`` (port 502 by default);
* ``modbus-rtu:PORT[?baud=19200&parity=E&stopbits=1]`` where PORT is a device
  path or any pyserial URL; the defaults are the device's (8E1 is the Modbus
  RTU specification's default framing).
"""

from __future__ import annotations

import struct
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any
from urllib.parse import parse_qs, urlsplit

from pymodbus import FramerType, ModbusException
from pymodbus.client import ModbusSerialClient, ModbusTcpClient
from pymodbus.exceptions import ConnectionException, ModbusIOException

from .errors import ChecksumError, ConnectionLost, DeviceError, ProtocolError, TransportTimeout

#: Exception codes of the Modbus application protocol v1.1b3, section 7.
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

PARITIES = {"N": "none", "E": "even", "O": "odd"}
BAUD_RATES = (1200, 2400, 4800, 9600, 19200, 38400, 57600, 115200)


@dataclass(frozen=True, slots=True)
class SerialSettings:
    """Serial line settings of an RTU link (8 data bits always)."""

    baudrate: int = 19200
    parity: str = "E"
    stopbits: int = 1

    @property
    def bits_per_char(self) -> int:
        """Start + 8 data + parity + stop bits."""
        return 1 + 8 + (0 if self.parity == "N" else 1) + self.stopbits


def rtu_crc(frame: bytes) -> int:
    """Modbus RTU CRC-16 (polynomial 0xA001 reflected, initial 0xFFFF), transmitted low byte first."""
    crc = 0xFFFF
    for byte in frame:
        crc ^= byte
        for _ in range(8):
            crc = (crc >> 1) ^ 0xA001 if crc & 1 else crc >> 1
    return crc


def parse_rtu_settings(query: str, default: SerialSettings) -> SerialSettings:
    """Serial settings from a URL query (``baud=9600&parity=N&stopbits=1``)."""
    opts = {k: v[-1] for k, v in parse_qs(query).items()}
    unknown = set(opts) - {"baud", "parity", "stopbits"}
    if unknown:
        raise ValueError(f"unknown Modbus RTU option(s) {', '.join(sorted(unknown))}; use baud, parity, stopbits")
    try:
        baud = int(opts.get("baud", default.baudrate))
        stopbits = int(opts.get("stopbits", default.stopbits))
    except ValueError as exc:
        raise ValueError(f"Modbus RTU baud and stopbits must be integers ({exc})") from None
    parity = opts.get("parity", default.parity).upper()
    if baud not in BAUD_RATES:
        raise ValueError(f"Modbus RTU baud {baud} is not one of {', '.join(map(str, BAUD_RATES))}")
    if parity not in PARITIES:
        raise ValueError(f"Modbus RTU parity {parity!r} must be N, E or O")
    if stopbits not in (1, 2):
        raise ValueError(f"Modbus RTU stopbits {stopbits} must be 1 or 2")
    return SerialSettings(baud, parity, stopbits)


class ModbusLink:
    """One Modbus device (``device_id``) on a pymodbus sync client."""

    def __init__(self, url: str, *, timeout_s: float = 1.0, device_id: int = 1,
                 rtu_default: SerialSettings = SerialSettings(), name: str = "Modbus device") -> None:
        self.url = url
        self.name = name
        self.device_id = device_id
        self.timeout_s = timeout_s
        self.serial: SerialSettings | None = None
        self._rx = b""  # last receive buffer pymodbus saw during the current request
        if url.startswith("modbus-tcp://"):
            parts = urlsplit(url)
            if not parts.hostname:
                raise ValueError(f"Modbus URL {url!r} has no host; use modbus-tcp://HOST:PORT")
            self.peer: str | None = f"{parts.hostname}:{parts.port or 502}"
            self.client: ModbusTcpClient | ModbusSerialClient = ModbusTcpClient(
                parts.hostname, port=parts.port or 502, timeout=timeout_s, retries=0,
                trace_packet=self._trace)
        elif url.startswith("modbus-rtu:"):
            port, _, query = url.removeprefix("modbus-rtu:").partition("?")
            if not port:
                raise ValueError(f"Modbus URL {url!r} has no serial port; use modbus-rtu:/dev/ttyUSB0?baud=19200")
            self.serial = parse_rtu_settings(query, rtu_default)
            self.peer = None  # a serial line: no connection to refuse or close
            self.client = ModbusSerialClient(
                port, framer=FramerType.RTU, baudrate=self.serial.baudrate, parity=self.serial.parity,
                stopbits=self.serial.stopbits, bytesize=8, timeout=timeout_s, retries=0,
                trace_packet=self._trace)
        else:
            raise ValueError(
                f"Modbus URL {url!r} must start with modbus-tcp:// or modbus-rtu: "
                "(e.g. modbus-tcp://192.168.0.10:502 or modbus-rtu:/dev/ttyUSB0?baud=19200&parity=E)"
            )

    def connect(self) -> None:
        """Open the connection; :class:`ConnectionLost` if that fails."""
        try:
            ok = self.client.connect()
        except (ModbusException, OSError) as exc:
            raise ConnectionLost(f"cannot connect to {self.name} at {self.url}: {exc}") from exc
        if not ok:
            self.client.close()
            why = (f"no Modbus answer from {self.peer} within {self.timeout_s} s / connection refused"
                   if self.peer is not None else "connection refused or port missing")
            raise ConnectionLost(f"cannot connect to {self.name} at {self.url}: {why}")

    def close(self) -> None:
        self.client.close()

    def _trace(self, sending: bool, data: bytes) -> bytes:
        if sending:
            self._rx = b""
        elif data:
            self._rx = bytes(data)
        return data

    def _garbled(self, what: str) -> ProtocolError:
        rx = self._rx
        shown = rx[:32].hex(" ") + (" ..." if len(rx) > 32 else "")
        if self.serial is not None and len(rx) >= 4 and rtu_crc(rx[:-2]) != int.from_bytes(rx[-2:], "little"):
            return ChecksumError(f"{self.name} {self.url}: {what}: reply failed the RTU CRC check ({shown})")
        return ProtocolError(f"{self.name} {self.url}: {what}: no valid Modbus reply in the bytes received ({shown})")

    def _lost(self, what: str, detail: str) -> ConnectionLost:
        return ConnectionLost(f"{self.name} {self.url}: {what}: connection lost: no Modbus answer from "
                              f"{self.peer} ({detail})")

    def call(self, what: str, fn: Callable[..., Any], *args: Any, **kwargs: Any) -> Any:
        """Run one client request; return the response or raise a typed error."""
        self._rx = b""
        try:
            rr = fn(*args, device_id=self.device_id, **kwargs)
        except ConnectionException as exc:
            self.client.close()  # make sure the next request reconnects
            if self.peer is not None:  # pymodbus's text ("closed 0.000 seconds into read ...") says less than this
                raise self._lost(what, "it closed the connection or refused a new one") from exc
            raise ConnectionLost(f"{self.name} {self.url}: {what}: connection lost ({exc})") from exc
        except ModbusIOException as exc:
            if self._rx:
                raise self._garbled(what) from exc
            raise TransportTimeout(f"{self.name} {self.url}: {what}: no response within {self.timeout_s} s") from exc
        except ModbusException as exc:
            raise ProtocolError(f"{self.name} {self.url}: {what}: {exc}") from exc
        except OSError as exc:
            self.client.close()
            if self.peer is not None:
                raise self._lost(what, (exc.strerror or str(exc)).lower()) from exc
            raise ConnectionLost(f"{self.name} {self.url}: {what}: {exc}") from exc
        except (struct.error, ValueError, IndexError, KeyError) as exc:  # pymodbus decoding a malformed PDU
            raise self._garbled(what) from exc
        if rr is None:
            raise TransportTimeout(f"{self.name} {self.url}: {what}: no response")
        if rr.isError():
            code = int(getattr(rr, "exception_code", 0))
            raise DeviceError(code, f"Modbus exception {code}: {MODBUS_EXCEPTION_TEXT.get(code, 'unknown code')}",
                              command=what)
        return rr

    def _registers(self, what: str, rr: Any, count: int) -> list[int]:
        regs = list(getattr(rr, "registers", None) or [])
        if len(regs) != count:
            raise ProtocolError(f"{self.name} {self.url}: {what}: {len(regs)} registers in the reply, not {count}")
        return regs

    def read_holding(self, address: int, count: int) -> list[int]:
        """Function 3: ``count`` holding registers from ``address``."""
        what = f"read {count} holding registers at {address}"
        return self._registers(what, self.call(what, self.client.read_holding_registers, address, count=count),
                               count)

    def read_input(self, address: int, count: int) -> list[int]:
        """Function 4: ``count`` input registers from ``address``."""
        what = f"read {count} input registers at {address}"
        return self._registers(what, self.call(what, self.client.read_input_registers, address, count=count),
                               count)

    def write_register(self, address: int, value: int, *, what: str = "") -> None:
        """Function 6: one holding register."""
        self.call(what or f"write {value} to register {address}", self.client.write_register, address, value)
