"""LinuxCNC configuration for live compensation through external axis offsets (docs/compensation.md,
"LinuxCNC: external axis offsets over mb2hal").  Pure text generators, no I/O.

Sources (LinuxCNC master, fetched from github:LinuxCNC/linuxcnc): ``docs/src/motion/external-offsets.adoc``
(``[AXIS_L] OFFSET_AV_RATIO``, pins ``axis.L.eoffset-enable / -scale / -counts``: the offset is the counts
accumulated since machine-on times the scale), ``src/emc/motion/axis.c`` (``axis.L.pos-cmd`` is reported
without the applied offsets), ``docs/src/drivers/mb2hal_HOWTO.ini`` and
``src/hal/user_comps/mb2hal/mb2hal_modbus.c`` (mb2hal is a Modbus master; ``fnct_03`` puts each 16-bit
register, unsigned, on ``mb2hal.TX.NAME.int`` / ``.float``), the man pages of ``comp``, ``sum2``,
``mux2``, ``bitslice`` and ``watchdog(9)`` (``ok-out`` false after a timeout until ``enable-in`` goes false
and true again).

What the generated files do: mb2hal reads registers 8-11 of the live-compensation interface (enable,
heartbeat, sample echo, offset counts) from the Modbus server that holds them; HAL sign-extends the
INT16 counts (mb2hal delivers 0-65535), feeds them to ``axis.L.eoffset-counts`` with ``eoffset-scale``
= one count (0.1 um or 0.01 arcsec) in machine units, and gates them to 0 while the heartbeat's bit 0
stops toggling for T (``watchdog``) or enable is 0: the offset then returns to 0 at the acceleration
``OFFSET_AV_RATIO`` reserves.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

AXES = "XYZABCUVW"
TX_NAME = "guideway"


@dataclass(frozen=True)
class LinuxCncLive:
    axis: str  # an axis letter, X Y Z A B C U V W
    rotary: bool
    server_ip: str  # the Modbus TCP server holding the interface's registers
    server_port: int = 502
    device_id: int = 1
    timeout_ms: int = 500  # the stale-heartbeat time T
    av_ratio: float = 0.1  # [AXIS_L] OFFSET_AV_RATIO: share of velocity / acceleration for the offset
    mb2hal_file: str = "guideway-live-mb2hal.ini"
    via: str = "mb2hal"  # "mb2hal" (offset side only) or "component" (the HAL component serving the interface)

    @property
    def hal_file(self) -> str:
        return "guideway-live.hal" if self.via == "mb2hal" else "guideway-live-component.hal"

    def __post_init__(self) -> None:
        if len(self.axis) != 1 or self.axis.upper() not in AXES:
            raise ValueError(f"--axis must be one axis letter of {' '.join(AXES)}, got {self.axis!r}")
        if not re.fullmatch(r"[0-9]{1,3}(\.[0-9]{1,3}){3}", self.server_ip):
            raise ValueError(f"mb2hal's TCP_IP is an IPv4 address (a.b.c.d), got {self.server_ip!r}")
        if not 1 <= self.server_port <= 65535:
            raise ValueError(f"port must be 1-65535, got {self.server_port}")
        if not 1 <= self.device_id <= 247:
            raise ValueError(f"device id (MB_SLAVE_ID) must be 1-247, got {self.device_id}")
        if not 0 < self.av_ratio <= 0.9:  # external-offsets.adoc: 0 <= r <= 0.9, 0 disables the offset
            raise ValueError(f"OFFSET_AV_RATIO must be > 0 and <= 0.9 (0 disables external offsets), "
                             f"got {self.av_ratio}")
        if self.via not in ("mb2hal", "component"):
            raise ValueError(f"--via must be mb2hal or component, got {self.via!r}")
        if self.timeout_ms < 1:
            raise ValueError(f"heartbeat timeout must be >= 1 ms, got {self.timeout_ms}")

    @property
    def letter(self) -> str:
        return self.axis.lower()

    @property
    def scale(self) -> float:
        """``eoffset-scale``: one count of register 11 in machine units (mm or deg)."""
        return 0.01 / 3600.0 if self.rotary else 0.1e-3


def mb2hal_ini(c: LinuxCncLive) -> str:
    """The mb2hal configuration: one transaction reading holding registers 8-11 as fast as it can."""
    return "\n".join([
        "# guideway live compensation: mb2hal reads the offset from the live-compensation interface",
        "# (docs/compensation.md, registers 8-11: enable, heartbeat, sample echo, offset counts INT16)",
        "[MB2HAL_INIT]",
        "INIT_DEBUG=1",
        "VERSION=1.1",
        "HAL_MODULE_NAME=mb2hal",
        "SLOWDOWN=0.0",
        "TOTAL_TRANSACTIONS=1",
        "",
        "[TRANSACTION_00]",
        "LINK_TYPE=tcp",
        f"TCP_IP={c.server_ip}",
        f"TCP_PORT={c.server_port}",
        f"MB_SLAVE_ID={c.device_id}",
        "FIRST_ELEMENT=8",
        "PIN_NAMES=enable,heartbeat,echo,counts",
        "MB_TX_CODE=fnct_03_read_holding_registers",
        f"MB_RESPONSE_TIMEOUT_MS={min(500, c.timeout_ms)}",
        f"MB_BYTE_TIMEOUT_MS={min(500, c.timeout_ms)}",
        f"HAL_TX_NAME={TX_NAME}",
        "MAX_UPDATE_RATE=0.0",
        "DEBUG=1",
        "",
    ])


def hal_lines(c: LinuxCncLive) -> str:
    """HAL: sign extension, heartbeat watchdog, gate, external offset pins of the axis."""
    a, tx = c.letter, f"mb2hal.{TX_NAME}"
    return "\n".join([
        f"# guideway live compensation on axis {c.axis.upper()} (docs/compensation.md): external axis offsets",
        f"loadusr -W mb2hal config={c.mb2hal_file}",
        "loadrt sum2 names=gw-neg",
        "loadrt comp names=gw-sign",
        "loadrt mux2 names=gw-signed,gw-gate",
        "loadrt conv_float_s32 names=gw-counts",
        "loadrt conv_s32_u32 names=gw-hb-u32,gw-en-u32",
        "loadrt bitslice names=gw-hb-bits,gw-en-bits personality=1,1",
        "loadrt and2 names=gw-ok",
        "loadrt watchdog num_inputs=1",
        *(f"addf {f} servo-thread" for f in ("gw-neg", "gw-sign", "gw-signed", "gw-gate", "gw-counts", "gw-hb-u32",
                                              "gw-en-u32", "gw-hb-bits", "gw-en-bits", "gw-ok",
                                              "watchdog.set-timeouts", "watchdog.process")),
        "# register 11 is INT16; mb2hal gives 0..65535: values above 32767 are negative (v - 65536)",
        "setp gw-neg.gain0 1.0",
        "setp gw-neg.offset -65536.0",
        "setp gw-sign.in0 32767.5",
        f"net gw-raw {tx}.counts.float => gw-neg.in0 gw-sign.in1 gw-signed.in0",
        "net gw-raw-neg gw-neg.out => gw-signed.in1",
        "net gw-is-neg gw-sign.out => gw-signed.sel",
        "# stale heartbeat or enable 0: the counts go to 0 and the offset returns to 0",
        "net gw-signed-counts gw-signed.out => gw-gate.in1",
        "setp gw-gate.in0 0.0",
        "net gw-live gw-ok.out => gw-gate.sel",
        "net gw-gated gw-gate.out => gw-counts.in",
        f"net gw-eoffset-counts gw-counts.out => axis.{a}.eoffset-counts",
        f"setp axis.{a}.eoffset-scale {c.scale:.12g}",
        f"setp axis.{a}.eoffset-enable 1",
        f"net gw-heartbeat {tx}.heartbeat.int => gw-hb-u32.in",
        "net gw-heartbeat-u32 gw-hb-u32.out => gw-hb-bits.in",
        "net gw-heartbeat-bit0 gw-hb-bits.out-00 => watchdog.input-0",
        f"setp watchdog.timeout-0 {c.timeout_ms / 1000.0:g}",
        f"net gw-enable {tx}.enable.int => gw-en-u32.in",
        "net gw-enable-u32 gw-en-u32.out => gw-en-bits.in",
        "net gw-enable-bit0 gw-en-bits.out-00 => watchdog.enable-in gw-ok.in1",
        "net gw-watchdog watchdog.ok-out => gw-ok.in0",
        f"# the compensator reads axis.{a}.pos-cmd (without the offset) and the direction from registers 2-7:",
        "# mb2hal writes 16-bit registers only, so that path needs a HAL user component (docs/compensation.md)",
        "",
    ])


def component_hal_lines(c: LinuxCncLive) -> str:
    """HAL for the component path (drivers/live_compensation/linuxcnc_component.py): the component serves
    the whole interface (position and direction in, offset out) and drives ``eoffset-counts`` itself."""
    a = c.letter
    return "\n".join([
        f"# guideway live compensation on axis {c.axis.upper()} through its HAL component (docs/compensation.md)",
        f"loadusr -Wn guideway-live python3 -m drivers.live_compensation.linuxcnc_component --axis {c.axis.upper()} "
        f"--port {c.server_port} --device-id {c.device_id} --timeout-ms {c.timeout_ms}",
        f"net gw-pos-cmd axis.{a}.pos-cmd => guideway-live.pos-cmd",
        "net gw-homed motion.is-all-homed => guideway-live.homed",
        f"net gw-eoffset-counts guideway-live.eoffset-counts => axis.{a}.eoffset-counts",
        f"setp axis.{a}.eoffset-scale {c.scale:.12g}",
        f"setp axis.{a}.eoffset-enable 1",
        "",
    ])


def ini_lines(c: LinuxCncLive) -> str:
    """The INI lines: the axis's share of velocity and acceleration for the offset, and the HAL file."""
    return "\n".join([
        "# guideway live compensation (docs/compensation.md): add to the machine's INI file",
        f"[AXIS_{c.axis.upper()}]",
        f"OFFSET_AV_RATIO = {c.av_ratio:g}",
        "",
        "[HAL]",
        f"HALFILE = {c.hal_file}",
        "",
    ])
