"""Part programs for ISO 230-2 positioning cycles (``guideway gcode``).

The program moves the axis through exactly the stops of the set-up's cycle
(:func:`acquisition.setup.cycles.cycle`): absolute straight moves at the set-up's
feed, overrun stops without dwell, and at each target a dwell followed by the
trigger mode's hand-over:

* ``in-position``: the PLC handshake of docs/modbus-map.md.  Fanuc: macro
  variables #500-#502 = target index, run, direction, then ``M100`` (a custom
  M-code whose ladder writes registers 200-204 and finishes (FIN) when the tool
  acknowledges, with UI000 = 1, or after its timer of ``[trigger] timeout_s``,
  with UI000 = 0); then ``IF[#1000EQ0]THEN#3000=1(...)``: no acknowledge stops
  the program with macro alarm 3001 and its message.  LinuxCNC: analog outputs
  0-2 = index, run, direction (``M68``), digital output 0 on (``M64 P0``), wait
  up to ``timeout_s`` for digital input 0 high (``M66 P0 L3 Q..``, the
  acknowledge), output off (``M65 P0``); ``#5399`` is -1 when the wait timed
  out, and the program then shows a message (``(MSG, ...)``) and ends (``M2``).
* ``stability``: the dwell only.
* ``manual``: ``M00`` (program stop): the operator captures, then presses Cycle Start.

Every measured target's block has a sequence number N<k> (k = 1, 2, ... in
cycle order) so a resumed run can restart the program at the right block.
"""

from __future__ import annotations

from saved_runs import nc_text

from .setup.positioning import PositioningSetup

INPOS_MCODE = 100
INPOS_ALARM = 1  # Fanuc macro alarm #3000 = 1: alarm 3001
INPOS_ALARM_TEXT = "GUIDEWAY NO ACK"  # Fanuc alarm messages: at most 26 characters
CYCLE_TITLES = {"linear": "standard test cycle", "step": "step cycle - Annex B"}


def _num(v: float, decimals: int = 4) -> str:
    text = f"{v:.{decimals}f}".rstrip("0")
    return text + "0" if text.endswith(".") else text


def part_program(setup: PositioningSetup) -> str:
    """The complete part program text (lines end with newline).

    Every string in it is checked against what the controller accepts (saved_runs.nc_text): the axis
    letter, the program number and each comment; anything else is a :class:`UserError`."""
    fanuc = setup.dialect == "fanuc"
    ax = nc_text.axis_letter(setup.axis_name, "the set-up's [axis] name")
    u, tr = setup.unit, setup.trigger
    stops = setup.stops()
    lines: list[str] = []

    def c(text: str) -> str:
        text = nc_text.comment(text, "a part-program comment")
        return f"({text.upper()})" if fanuc else f"({text})"

    # "linear cycle" is the standard's name of its standard test cycle, not the axis type: say which
    # cycle in words that cannot be read as the axis (no nested parentheses in a G-code comment)
    title = f"guideway ISO 230-2 {CYCLE_TITLES[setup.cycle]}, {setup.axis_type} axis {ax}"
    if fanuc:
        number = nc_text.program_number(setup.program_number, "the set-up's [gcode] program_number")
        lines += ["%", f"O{number:04d} {c(title)}"]
    else:
        lines.append(c(title))
    lines.append(c(f"{len(setup.targets)} targets, {setup.runs} runs each direction, overrun {_num(setup.overrun)} "
                   f"{u}, dwell {_num(tr.dwell_s, 2)} s, trigger {tr.mode}"))
    lines.append("G90 G94 G21" if setup.axis_type == "linear" else "G90 G94")
    feed = f"F{_num(setup.feed_per_min, 1)}"
    dwell = f"G04 X{_num(tr.dwell_s, 3)}" if fanuc else f"G4 P{_num(tr.dwell_s, 3)}"
    k = 0
    for i, s in enumerate(stops):
        move = f"G01 {ax}{_num(s.position)} {feed}" if i == 0 else f"G01 {ax}{_num(s.position)}"
        if not s.target_index:
            lines.append(f"{move} {c('overrun, run ' + str(s.run))}")
            continue
        k += 1
        arrow = "+" if s.direction > 0 else "-"
        lines.append(f"N{k} {move} {c(f'run {s.run} {arrow} target {s.target_index}')}")
        lines.append(dwell)
        if tr.mode == "in-position":
            if fanuc:
                lines += [f"#500={s.target_index}", f"#501={s.run}", f"#502={s.direction}", f"M{INPOS_MCODE}",
                          f"IF[#1000EQ0]THEN#3000={INPOS_ALARM}({INPOS_ALARM_TEXT})"]
            else:
                # no comment on an O-word line, one O number per if-block (LinuxCNC O-code rules)
                msg = nc_text.comment(f"MSG, guideway: no acknowledge within {_num(tr.timeout_s, 1)} s at run "
                                      f"{s.run} {arrow} target {s.target_index}, program ended, check the tool "
                                      "and its Modbus link", "a part-program message")
                lines += [f"M68 E0 Q{s.target_index}", f"M68 E1 Q{s.run}", f"M68 E2 Q{s.direction}", "M64 P0",
                          f"M66 P0 L3 Q{_num(tr.timeout_s, 1)}", "M65 P0", f"o{k} if [#5399 LT 0]", f"({msg})",
                          "M2", f"o{k} endif"]
        elif tr.mode == "manual":
            lines.append("M00")
    lines.append("M30" if fanuc else "M2")
    if fanuc:
        lines.append("%")
    return "\n".join(lines) + "\n"
