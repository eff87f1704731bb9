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
"""

from __future__ import annotations

import asyncio
import contextlib
import threading
from collections.abc import Callable

from pymodbus import FramerType
from pymodbus.pdu.device import ModbusDeviceIdentification
from pymodbus.server import ModbusSerialServer, ModbusTcpServer
from pymodbus.simulator import SimDevice

from .pty_bridge import PtyBridge

WIRE_KINDS = {"drop", "corrupt", "close"}
TRANSPORTS = ("tcp", "rtu")


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
        identity: ModbusDeviceIdentification | None = None,
        wire_faults: WireFaults | None = None,
    ) -> None:
        if transport not in TRANSPORTS:
            raise ValueError(f"transport must be one of {TRANSPORTS}, not {transport!r}")
        self.transport = transport
        self._devices = devices
        self._framer = framer or (FramerType.SOCKET if transport == "tcp" else FramerType.RTU)
        self._want_port = port
        first = devices[0] if isinstance(devices, list) else devices
        self._identity = identity or first.identity  # the device's own identity answers FC 43/14
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
        """The endpoint a driver connects to."""
        if self.bridge is not None:
            # The pty cannot carry parity settings (see mocks.pty_bridge): the driver side opens it at 8N1.
            return f"modbus-rtu:{self.bridge.path_b}?baud={self.baudrate}&parity=N"
        return f"modbus-tcp://127.0.0.1:{self.port}"

    def _close_connections(self) -> None:
        server = self.server
        if server is None:
            return
        for conn in list(getattr(server, "active_connections", {}).values()):
            with contextlib.suppress(Exception):  # best effort: the connection may be closing already
                conn.close()

    async def _start(self) -> None:
        common = {"identity": self._identity, "framer": self._framer,
                  "trace_packet": self.wire_faults.trace_packet}
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
