"""What a controller program or table accepts from us: every string the tool puts into NC code.

A part program (``guideway gcode``, Fanuc and LinuxCNC dialects) and a compensation file (``guideway
export``: Fanuc parameter listing, Siemens LEC table) are read by a machine that moves.  A name copied
into them unchecked could end a comment and add a block (``X\\nG0 Z-500``: a rapid move).  So each
string is checked against what that controller accepts, and anything else is refused with one line:

* an axis address: one letter of X Y Z A B C U V W (ISO 6983 / RS-274 axis words; Fanuc and LinuxCNC);
* a Fanuc program number: O1 ... O9999;
* a Siemens machine-axis identifier (``$AA_ENC_COMP[...,AX]``): a letter, then letters, digits or ``_``,
  at most 31 characters (Sinumerik identifier rules);
* a comment: printable ASCII (space ... ``~``) without ``(`` ``)`` (a G-code comment ends at the first
  ``)`` and does not nest), ``;`` (LinuxCNC and Siemens: the rest of the line is a comment), ``%`` (the
  Fanuc tape start / end) or a newline, at most :data:`COMMENT_MAX_CHARS` characters.
"""

from __future__ import annotations

import re

from .errors import UserError

AXIS_LETTERS = "XYZABCUVW"
PROGRAM_NUMBERS = (1, 9999)  # Fanuc O-numbers (4 digits; O0 is not a program)
COMMENT_MAX_CHARS = 120
_SIEMENS_AXIS = re.compile(r"[A-Za-z][A-Za-z0-9_]{0,30}")
_COMMENT_FORBIDDEN = "();%"


def axis_letter(name: object, what: str) -> str:
    """``name`` as an axis address (upper case); :class:`UserError` naming ``what`` otherwise."""
    if isinstance(name, str) and len(name) == 1 and name.upper() in AXIS_LETTERS:
        return name.upper()
    raise UserError(f"{what} must be one axis letter of {' '.join(AXIS_LETTERS)} (it is written into NC code), "
                    f"got {_shown(name)}")


def program_number(number: object, what: str) -> int:
    """A Fanuc program number O1 ... O9999; :class:`UserError` naming ``what`` otherwise."""
    lo, hi = PROGRAM_NUMBERS
    if isinstance(number, int) and not isinstance(number, bool) and lo <= number <= hi:
        return number
    raise UserError(f"{what} must be a whole number {lo} ... {hi} (a Fanuc O-number), got {_shown(number)}")


def siemens_axis(name: object, what: str) -> str:
    """A Sinumerik machine-axis identifier (``X1``, ``AX3``); :class:`UserError` naming ``what`` otherwise."""
    if isinstance(name, str) and _SIEMENS_AXIS.fullmatch(name):
        return name
    raise UserError(f"{what} must be a Siemens machine-axis name (a letter, then letters, digits or _, at most "
                    f"31 characters, e.g. X1), got {_shown(name)}")


def comment(text: str, what: str) -> str:
    """``text`` if a controller comment can hold it (module docstring); :class:`UserError` naming ``what``."""
    bad = next((c for c in text if not " " <= c <= "~" or c in _COMMENT_FORBIDDEN), None)
    if bad is not None:
        raise UserError(f"{what} cannot go into an NC comment: it holds {bad!r} (only printable ASCII without "
                        f"{' '.join(_COMMENT_FORBIDDEN)} or line breaks), in {_shown(text)}")
    if len(text) > COMMENT_MAX_CHARS:
        raise UserError(f"{what} is {len(text)} characters long; an NC comment holds at most {COMMENT_MAX_CHARS}")
    return text


def _shown(value: object) -> str:
    """``value`` for a one-line message: repr (line breaks escaped), shortened."""
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."
