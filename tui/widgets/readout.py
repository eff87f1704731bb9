"""Text of the live readings: sensor value and status, every interferometer channel, status flags,
environment (the formats of ``guideway devices probe``), as Textual markup: text from the devices
is escaped (the status flags are written in brackets)."""

from __future__ import annotations

import math

from textual.markup import escape

from acquisition.monitor import LiveReading
from acquisition.probe import set_flags, status_flags


def sensor_line(r: LiveReading | None) -> str:
    if r is None or not r.has_sensor:
        return "sensor: [dim]waiting for a reading[/dim]"
    value = f"{r.sensor_mm:+.5f} mm" if math.isfinite(r.sensor_mm) else "no value"
    status = r.sensor_status if r.sensor_status == "ok" else f"[red]{r.sensor_status}[/red]"
    rate = f"  {r.sensor_rate_hz:,.0f} values/s, lost {r.frames_lost}" if r.sensor_count > 1 else ""
    return f"sensor: [b]{value}[/b] {status}{rate}"


def interferometer_lines(r: LiveReading | None) -> list[str]:
    ifm = r.interferometer if r is not None else None
    if ifm is None:
        return ["interferometer: [dim]waiting for a reading[/dim]"]
    return [
        f"interferometer: {escape(status_flags(ifm.status))}",
        f"  position {ifm.position_mm:+.6f} mm  stry {ifm.stry_um:+.3f} um  strz {ifm.strz_um:+.3f} um",
        f"  pitch {ifm.pitch_urad:+.2f} urad  yaw {ifm.yaw_urad:+.2f} urad  roll {ifm.roll_urad:+.2f} urad",
        f"  air {ifm.air_temp_c:.3f} C  {ifm.air_pressure_hpa:.2f} hPa  {ifm.humidity_pct:.1f} %RH  "
        f"material {ifm.material_temp_c:.3f} C",
    ] + ([f"  rotary angle {r.angle_deg:+.5f} deg from the datum"] if math.isfinite(r.angle_deg) else [])


def controller_state(r: LiveReading | None) -> str:
    """The controller's set flags and sequence in a few words (the capture screen's status line)."""
    ifm = r.interferometer if r is not None else None
    if ifm is None:
        return "[dim]waiting for a reading[/dim]"
    st = ifm.status
    error = f" [red]error {st.error_code}: {escape(st.error_text or 'unknown error')}[/red]" \
        if st.error or st.error_code else ""
    return f"{set_flags(st)}, sequence {st.sequence}{error}"


def readout_text(r: LiveReading | None, *, sensor: bool = True) -> str:
    lines = ([sensor_line(r)] if sensor else []) + interferometer_lines(r)
    if r is not None and r.problem:
        lines.append(f"[red]{escape(r.problem)}[/red]")
    return "\n".join(lines)


def bar(value: float, limit: float, width: int = 24) -> str:
    """``value`` against ``limit`` as a bar (full = the limit; beyond it red)."""
    if not (math.isfinite(value) and limit > 0):
        return "[dim]" + "·" * width + "[/dim]   n/a"
    filled = min(width, round(width * value / limit))
    colour = "green" if value <= limit else "red"
    return f"[{colour}]{'█' * filled}[/{colour}][dim]{'·' * (width - filled)}[/dim] {value:6.3f} / {limit:g} um"
