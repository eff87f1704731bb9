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

* ``modbus-tcp://HOST[:PORT][?device_id=N]`` (port 502 by default);
* ``modbus-rtu:PORT[?baud=19200&parity=E&stopbits=1&device_id=N]`` where PORT is a
  device path or any pyserial URL; the defaults are the device's (8E1 is the
  Modbus RTU specification's default framing).

``device_id`` is the unit id (Modbus TCP, 0-255: a device behind a TCP/RTU
gateway is reached by its serial address) or the slave address (RTU, 1-247);
default 1.  Any other option is refused with a message naming it.
"""

from __future__ import annotations

import struct
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any
from urllib.parse import parse_qsl, urlsplit

from pymodbus import FramerType, ModbusException
from pymodbus.client import ModbusSerialClient, ModbusTcpClient
from pymodbus.exceptions import ConnectionException, ModbusIOException

from .errors import ChecksumError, ConnectionLost, DeviceError, ProtocolError, TransportTimeout, with_context

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


RTU_OPTIONS = ("baud", "parity", "stopbits", "device_id")
TCP_OPTIONS = ("device_id",)
#: Valid device ids: a TCP unit identifier is one byte; on a serial line 0 is broadcast and 248-255 are reserved.
DEVICE_IDS = {"tcp": range(0, 256), "rtu": range(1, 248)}
DEFAULT_DEVICE_ID = 1


def _options(query: str, allowed: tuple[str, ...], kind: str) -> dict[str, str]:
    """URL query options (the last of repeated keys wins); a ValueError naming unknown ones."""
    opts = dict(parse_qsl(query, keep_blank_values=True))
    unknown = set(opts) - set(allowed)
    if unknown:
        raise ValueError(f"unknown Modbus {kind} option(s) {', '.join(sorted(unknown))}; use {', '.join(allowed)}")
    return opts


def _device_id(opts: dict[str, str], transport: str) -> int | None:
    """``device_id`` from the URL options, checked against the transport's range; None when not given."""
    if "device_id" not in opts:
        return None
    valid = DEVICE_IDS[transport]
    try:
        device_id = int(opts["device_id"])
    except ValueError:
        device_id = -1
    if device_id not in valid:
        raise ValueError(f"Modbus {transport.upper()} device_id {opts['device_id']!r} must be a whole number "
                         f"{valid.start}..{valid.stop - 1}")
    return device_id


def parse_rtu_settings(query: str, default: SerialSettings) -> SerialSettings:
    """Serial settings from a URL query (``baud=9600&parity=N&stopbits=1``; ``device_id`` is accepted and
    left to :func:`parse_modbus_url`)."""
    opts = _options(query, RTU_OPTIONS, "RTU")
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


@dataclass(frozen=True, slots=True)
class ModbusEndpoint:
    """A parsed Modbus URL: TCP host and port, or RTU serial port and line settings; the device id it names."""

    transport: str  # "tcp" or "rtu"
    host: str = ""
    port: int = 502
    serial_port: str = ""
    serial: SerialSettings | None = None
    device_id: int | None = None  # None: the URL does not say (the caller's default, 1)


def parse_modbus_url(url: str, rtu_default: SerialSettings = SerialSettings()) -> ModbusEndpoint:
    """Parse ``modbus-tcp://HOST[:PORT][?device_id=N]`` or ``modbus-rtu:PORT[?baud=..&parity=..&stopbits=..
    &device_id=N]``; a one-line ValueError naming what is wrong."""
    if url.startswith("modbus-tcp://"):
        parts = urlsplit(url)
        try:
            port = parts.port or 502
        except ValueError:
            raise ValueError(f"Modbus URL {url!r} has a bad port; use modbus-tcp://HOST:PORT (1-65535)") from None
        if not parts.hostname:
            raise ValueError(f"Modbus URL {url!r} has no host; use modbus-tcp://HOST:PORT")
        if parts.path not in ("", "/") or parts.fragment:
            raise ValueError(f"Modbus URL {url!r}: nothing may follow HOST:PORT except ?device_id=N")
        opts = _options(parts.query, TCP_OPTIONS, "TCP")
        return ModbusEndpoint("tcp", host=parts.hostname, port=port, device_id=_device_id(opts, "tcp"))
    if url.startswith("modbus-rtu:"):
        port_name, _, query = url.removeprefix("modbus-rtu:").partition("?")
        if not port_name:
            raise ValueError(f"Modbus URL {url!r} has no serial port; use modbus-rtu:/dev/ttyUSB0?baud=19200")
        serial = parse_rtu_settings(query, rtu_default)
        return ModbusEndpoint("rtu", serial_port=port_name, serial=serial,
                              device_id=_device_id(_options(query, RTU_OPTIONS, "RTU"), "rtu"))
    raise ValueError(
        f"Modbus URL {url!r} must start with modbus-tcp:// or modbus-rtu: "
        "(e.g. modbus-tcp://192.168.0.10:502 or modbus-rtu:/dev/ttyUSB0?baud=19200&parity=E)"
    )


class ModbusLink:
    """One Modbus device (``device_id``) on a pymodbus sync client.

    The device id comes from the URL's ``device_id=`` option, else from ``device_id``, else 1;
    both given and different is a ValueError.
    """

    def __init__(self, url: str, *, timeout_s: float = 1.0, device_id: int | None = None,
                 rtu_default: SerialSettings = SerialSettings(), name: str = "Modbus device") -> None:
        self.url = url
        self.name = name
        self.timeout_s = timeout_s
        self._rx = b""  # last receive buffer pymodbus saw during the current request
        ep = parse_modbus_url(url, rtu_default)
        if ep.device_id is not None and device_id is not None and ep.device_id != device_id:
            raise ValueError(f"Modbus URL {url!r} names device_id={ep.device_id} but device id {device_id} "
                             "was asked for; give it once")
        self.device_id = next((d for d in (ep.device_id, device_id) if d is not None), DEFAULT_DEVICE_ID)
        self.serial: SerialSettings | None = ep.serial
        if ep.serial is None:
            self.peer: str | None = f"{ep.host}:{ep.port}"
            self.client: ModbusTcpClient | ModbusSerialClient = ModbusTcpClient(
                ep.host, port=ep.port, timeout=timeout_s, retries=0, trace_packet=self._trace)
        else:
            self.peer = None  # a serial line: no connection to refuse or close
            self.client = ModbusSerialClient(
                ep.serial_port, framer=FramerType.RTU, baudrate=ep.serial.baudrate, parity=ep.serial.parity,
                stopbits=ep.serial.stopbits, bytesize=8, timeout=timeout_s, retries=0,
                trace_packet=self._trace)

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
            raise TransportTimeout(f"{self.name} {self.url}: {what}: no response within {self.timeout_s} s "
                                   f"(device id {self.device_id})") from exc
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
            raise with_context(DeviceError(code, f"Modbus exception {code}: "
                                           f"{MODBUS_EXCEPTION_TEXT.get(code, 'unknown code')}", command=what),
                               f"{self.name} {self.url}")
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
