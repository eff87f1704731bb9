"""pymodbus's own server (SimDevice/SimData) in a thread, on loopback TCP or on
Modbus RTU over a pty null-modem (:class:`~mocks.pty_bridge.PtyBridge`), plus
reply-level fault injection through the server's ``trace_packet`` hook.

:class:`WireFaults` is armed by an emulator's action hook for the request it
is serving and applied to the next frame the server sends:

* ``drop`` - the reply is not sent (the client times out);
* ``corrupt`` - one bit of the frame check is flipped (RTU: the high CRC
  byte; TCP has no frame check, so a bit of the MBAP protocol identifier,
  which the client's framer must reject);
* ``close`` - the reply is not sent and the server closes the connection
  (TCP; on a serial line there is no connection to close, so it acts as drop).

Like a real device the server answers only at the unit ids of its devices: a
request for another one gets no reply on a serial line (RTU framing) and, on
Modbus TCP, exception 11 (gateway target device failed to respond), which is
what a TCP/RTU gateway answers for a serial address nobody answers at.

Device identification (function 43/14) is answered from a :class:`DeviceIdentity`
in one of the ways real devices do (``access``), per server, not from pymodbus's
process-wide identity block.
"""

from __future__ import annotations

import asyncio
import contextlib
import threading
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from pymodbus import FramerType
from pymodbus.constants import ExcCodes
from pymodbus.pdu import ExceptionResponse, ModbusPDU
from pymodbus.pdu.device import ModbusDeviceIdentification
from pymodbus.pdu.mei_message import ReadDeviceInformationRequest, ReadDeviceInformationResponse
from pymodbus.server import ModbusSerialServer, ModbusTcpServer
from pymodbus.simulator import SimDevice

from .pty_bridge import PtyBridge

WIRE_KINDS = {"drop", "corrupt", "close"}
TRANSPORTS = ("tcp", "rtu")
IDENTITY_ACCESS = ("category", "stream", "basic")
#: Object ids of function 43/14 by read code: 1 basic, 2 regular (3 extended: no private objects here).
_CATEGORY = {1: range(0, 3), 2: range(3, 7), 3: range(3, 7)}


@dataclass(frozen=True)
class DeviceIdentity:
    """What a device answers to read device identification (function 43/14).

    ``objects``: object id -> text (0 vendor, 1 product code, 2 revision, 3 vendor URL,
    4 product name, 5 model name, 6 user application name).  ``access``, how read codes
    map to objects:

    * ``category``: each read code answers its own category only - basic (1) objects 0-2,
      regular (2) objects 3-6.  Many field devices do this; a tool that asks one code sees
      half of the identity.
    * ``stream``: a read code answers every object up to its category (regular: 0-6), as
      pymodbus's own server does.
    * ``basic``: basic conformity only; the regular code is refused with exception 3.

    Read code 4 (one object) answers that object, exception 2 when the device has none.
    """

    objects: Mapping[int, str] = field(default_factory=dict)
    access: str = "category"

    def __post_init__(self) -> None:
        if self.access not in IDENTITY_ACCESS:
            raise ValueError(f"identity access must be one of {IDENTITY_ACCESS}, not {self.access!r}")

    @classmethod
    def from_pymodbus(cls, identity: ModbusDeviceIdentification, access: str = "category") -> DeviceIdentity:
        texts = {oid: identity[oid] for oid in range(7)}
        return cls({oid: str(v) for oid, v in texts.items() if v}, access)

    def answer(self, read_code: int, object_id: int) -> dict[int, str] | ExcCodes:
        """The objects of one request, or the exception code it is refused with."""
        if read_code == 4:
            return {object_id: self.objects[object_id]} if object_id in self.objects else ExcCodes.ILLEGAL_ADDRESS
        if read_code not in _CATEGORY or (self.access == "basic" and read_code != 1):
            return ExcCodes.ILLEGAL_VALUE
        ids = range(0, _CATEGORY[read_code].stop) if self.access == "stream" else _CATEGORY[read_code]
        return {oid: self.objects[oid] for oid in ids if oid in self.objects and oid >= object_id}


class _IdentityRequest(ReadDeviceInformationRequest):
    """A received function 43/14 request, answered from the server's :class:`DeviceIdentity`."""

    identity = DeviceIdentity()

    async def datastore_update(self, context: Any, device_id: int) -> ModbusPDU:
        _ = context
        info = self.identity.answer(self.read_code, self.object_id)
        if isinstance(info, ExcCodes):
            return ExceptionResponse(self.function_code, info)
        response = ReadDeviceInformationResponse(read_code=self.read_code, information=info, dev_id=device_id,
                                                 transaction_id=self.transaction_id)
        response.conformity = 0x81 if self.identity.access == "basic" else 0x82  # stream access, level 1 / 2
        return response


class _NoDevice(ModbusPDU):
    """A request for a unit id nobody answers at, behind a gateway: exception 11."""

    def __init__(self, request: ModbusPDU) -> None:
        super().__init__(dev_id=request.dev_id, transaction_id=request.transaction_id)
        self.function_code = request.function_code

    async def datastore_update(self, context: Any, device_id: int) -> ModbusPDU:
        _ = context, device_id
        return ExceptionResponse(self.function_code, ExcCodes.GATEWAY_NO_RESPONSE)


class WireFaults:
    """One pending reply fault, armed by an emulator and consumed by the server's send."""

    def __init__(self) -> None:
        self.pending: str | None = None
        self.close_link: Callable[[], None] = lambda: None
        self.framer = FramerType.SOCKET
        self.applied: list[str] = []

    def arm(self, kind: str) -> None:
        if kind not in WIRE_KINDS:
            raise ValueError(f"unknown wire fault {kind!r}")
        self.pending = kind

    def trace_packet(self, sending: bool, data: bytes) -> bytes:
        """pymodbus ``trace_packet`` hook: may rewrite or swallow an outgoing frame."""
        if not sending or self.pending is None or not data:
            return data
        kind, self.pending = self.pending, None
        self.applied.append(kind)
        if kind == "corrupt":
            frame = bytearray(data)
            pos = len(frame) - 1 if self.framer == FramerType.RTU else 2  # CRC high byte / protocol id
            frame[pos] ^= 0x80
            return bytes(frame)
        if kind == "close":
            self.close_link()
        return b""


class ModbusServerThread:
    """A pymodbus server running in its own thread and event loop.

    ``transport="tcp"``: Modbus TCP on 127.0.0.1 (``port`` 0 = ephemeral).
    ``transport="rtu"``: Modbus RTU (pymodbus's serial server and RTU framer)
    on one end of a pty bridge; the driver opens the other end, :attr:`url`.
    ``identity``: the answers to function 43/14 (a :class:`DeviceIdentity`; a pymodbus
    identity is served with ``category`` access; default: the first device's).
    Only the devices' unit ids are answered (see the module docstring).
    """

    def __init__(
        self,
        devices: SimDevice | list[SimDevice],
        *,
        port: int = 0,
        framer: FramerType | None = None,
        transport: str = "tcp",
        baudrate: int = 19200,
        parity: str = "E",
        identity: DeviceIdentity | ModbusDeviceIdentification | None = None,
        wire_faults: WireFaults | None = None,
    ) -> None:
        if transport not in TRANSPORTS:
            raise ValueError(f"transport must be one of {TRANSPORTS}, not {transport!r}")
        self.transport = transport
        self._devices = devices
        self._framer = framer or (FramerType.SOCKET if transport == "tcp" else FramerType.RTU)
        self._want_port = port
        listed = devices if isinstance(devices, list) else [devices]
        self.unit_ids = frozenset(d.id for d in listed)
        identity = identity or listed[0].identity  # the device's own identity answers FC 43/14
        self.identity = (DeviceIdentity.from_pymodbus(identity) if isinstance(identity, ModbusDeviceIdentification)
                         else identity or DeviceIdentity())
        self.baudrate = baudrate
        self.parity = parity
        self.wire_faults = wire_faults or WireFaults()
        self.wire_faults.framer = self._framer
        self.bridge: PtyBridge | None = None
        if transport == "rtu":
            self.bridge = PtyBridge(baudrate=baudrate, bits_per_char=11 if parity != "N" else 10)
        self._loop = asyncio.new_event_loop()
        self._ready = threading.Event()
        self._error: BaseException | None = None
        self.server: ModbusTcpServer | ModbusSerialServer | None = None
        self.port = 0
        self._thread = threading.Thread(target=self._run, name=f"modbus-sim-{transport}", daemon=True)
        self._thread.start()
        if not self._ready.wait(10):
            self.stop()
            raise RuntimeError("simulated Modbus server did not start")
        if self._error is not None:
            self.stop()
            raise RuntimeError(f"simulated Modbus server failed: {self._error}") from self._error

    @property
    def url(self) -> str:
        """The endpoint a driver connects to (with ``device_id=`` unless the device is at unit id 1)."""
        unit = "" if 1 in self.unit_ids else f"device_id={min(self.unit_ids)}"
        if self.bridge is not None:
            # The pty cannot carry parity settings (see mocks.pty_bridge): the driver side opens it at 8N1.
            return f"modbus-rtu:{self.bridge.path_b}?baud={self.baudrate}&parity=N" + (f"&{unit}" if unit else "")
        return f"modbus-tcp://127.0.0.1:{self.port}" + (f"?{unit}" if unit else "")

    def trace_pdu(self, sending: bool, pdu: ModbusPDU) -> ModbusPDU | None:
        """pymodbus ``trace_pdu`` hook: answer only our unit ids, and identification from our identity."""
        if sending:
            return pdu
        if pdu.dev_id not in self.unit_ids:
            # a serial device stays silent for another address; a TCP gateway reports that nobody answered
            return None if self._framer == FramerType.RTU else _NoDevice(pdu)
        if isinstance(pdu, ReadDeviceInformationRequest):
            request = _IdentityRequest(read_code=pdu.read_code, object_id=pdu.object_id, dev_id=pdu.dev_id,
                                       transaction_id=pdu.transaction_id)
            request.identity = self.identity
            return request
        return pdu

    def _close_connections(self) -> None:
        server = self.server
        if server is None:
            return
        for conn in list(getattr(server, "active_connections", {}).values()):
            with contextlib.suppress(Exception):  # best effort: the connection may be closing already
                conn.close()

    async def _start(self) -> None:
        common = {"framer": self._framer, "trace_packet": self.wire_faults.trace_packet,
                  "trace_pdu": self.trace_pdu}
        if self.bridge is not None:
            self.server = ModbusSerialServer(self._devices, port=self.bridge.path_a, baudrate=self.baudrate,
                                             parity="N", stopbits=1, bytesize=8, **common)
        else:
            self.server = ModbusTcpServer(self._devices, address=("127.0.0.1", self._want_port), **common)
        if self.bridge is None:  # a serial line has no connection to close: ``close`` acts as ``drop``
            self.wire_faults.close_link = self._close_connections
        await self.server.serve_forever(background=True)
        if self.bridge is None:
            self.port = self.server.transport.sockets[0].getsockname()[1]  # type: ignore[union-attr]

    def _run(self) -> None:
        asyncio.set_event_loop(self._loop)
        try:
            self._loop.run_until_complete(self._start())
        except BaseException as exc:  # reported to the starting thread
            self._error = exc
            self._loop.close()
            self._ready.set()
            return
        self._ready.set()
        self._loop.run_forever()
        self._finish_pending()
        self._loop.close()

    def _finish_pending(self) -> None:
        """Cancel and await the tasks still pending when the loop stopped.

        pymodbus runs each request in a task it does not keep; one still waiting (a ``delay``
        fault) when the server stops would otherwise be destroyed pending, which asyncio logs
        ("Task was destroyed but it is pending!") on stderr.
        """
        pending = asyncio.all_tasks(self._loop)
        for task in pending:
            task.cancel()
        if pending:
            self._loop.run_until_complete(asyncio.gather(*pending, return_exceptions=True))
        self._loop.run_until_complete(self._loop.shutdown_asyncgens())

    def stop(self) -> None:
        if self.server is not None and self._loop.is_running():
            fut = asyncio.run_coroutine_threadsafe(self.server.shutdown(), self._loop)
            with contextlib.suppress(Exception):  # best effort at shutdown
                fut.result(timeout=5)
        if self._loop.is_running():
            self._loop.call_soon_threadsafe(self._loop.stop)
        self._thread.join(timeout=5)
        if self.bridge is not None:
            self.bridge.close()
