"""Set-up files of either kind: validate a TOML structure by its ``kind`` and write one back.

The TUI's set-up screen edits the same TOML structure the set-up loaders read
(``docs/setup-*.toml``) and checks it with them, so its messages are the
loader's; :func:`setup_toml_text` writes the structure as a set-up file.
"""

from __future__ import annotations

import copy
import math
import re
from typing import TYPE_CHECKING, Any

from saved_runs.errors import SetupError
from saved_runs.toml_file import toml_string

from .straightness import StraightnessSetup, straightness_setup_from_dict

if TYPE_CHECKING:
    from .positioning import PositioningSetup

KINDS = ("straightness", "positioning")


def setup_kind(data: dict[str, Any]) -> str:
    """The run kind a set-up structure describes (``kind``; default straightness, as the loader's)."""
    kind = data.get("kind", "straightness")
    if kind not in KINDS:
        raise SetupError(f"kind is {kind!r}; use one of {', '.join(KINDS)}")
    return str(kind)


def setup_from_dict(data: dict[str, Any], source: str = "setup") -> StraightnessSetup | PositioningSetup:
    """Validate ``data`` with the loader of its kind (the checks of ``guideway acquire``)."""
    if setup_kind(data) == "straightness":
        return straightness_setup_from_dict(data, source)
    from .positioning import positioning_setup_from_dict  # (pandas: a straightness set-up is checked without it)

    return positioning_setup_from_dict(data, source)


# Names some messages use for a key of a table (the run.json name of a set-up key).
KEY_ALIASES = {"block_length_mm": ("block", "length_mm"), "stations": ("block", "stations"),
               "samples_per_reading": ("block", "samples_per_reading")}
# A valid value for a required key, put in its place once its own problem is listed, so that the
# loader goes on to the problems after it.
STAND_INS = {("block", "length_mm"): 100.0, ("block", "stations"): 2,
             ("geometry", "mirror_mm"): [50.0, 110.0, 0.0], ("geometry", "sensor_mm"): [150.0, 0.0, 40.0],
             ("axis", "end_mm"): 1000.0, ("axis", "end_deg"): 360.0}


def _key_of(message: str, data: dict[str, Any]) -> tuple[str | None, str] | None:
    """The (table, key) of ``data`` a loader message names (table None: top level), or None."""
    if m := re.search(r"unknown key '([^']+)' in (?:\[([\w-]+)\]|top level)", message):
        return m.group(2), m.group(1)
    for m in re.finditer(r"\[([\w-]+)\] (\w+)", message):
        table, key = m.group(1), m.group(2)
        if isinstance(data.get(table), dict):
            if key in data[table]:
                return table, key
            if key == "targets":  # "[axis] targets: ..." names the list of the axis's unit
                return next(((table, k) for k in data[table] if k.startswith("targets_")), None)
    for name, (table, key) in KEY_ALIASES.items():
        if re.search(rf"(?<![\w\]] ){name}\b", message) and key in (data.get(table) or {}):
            return table, key
    first = re.match(r"(\w+)\b", message)
    if first and first.group(1) in data and not isinstance(data[first.group(1)], dict):
        return None, first.group(1)
    return None


def setup_problems(data: dict[str, Any], source: str = "setup", limit: int = 40) -> list[str]:
    """Every problem of a set-up structure the loader finds, not only the first (the TUI lists them
    all; ``guideway acquire`` stops at the first, one line).

    The loader is run again with the key each message names taken out (a required key replaced by
    a valid stand-in), until it takes the set-up, names no key it can take out, or repeats itself.
    """
    work = copy.deepcopy(data)
    problems: list[str] = []
    taken: set[tuple[str | None, str]] = set()
    for _ in range(limit):
        try:
            setup_from_dict(work, source)
            break
        except SetupError as exc:
            message = str(exc)
        if message in problems:
            break
        problems.append(message)
        where = _key_of(message, work)
        table = work if where is None or where[0] is None else work.get(where[0])
        if where is None or where in taken or not isinstance(table, dict):
            break
        taken.add(where)
        if where in STAND_INS:  # a required key: a valid value in its place, so the loader goes on
            table[where[1]] = STAND_INS[where]  # type: ignore[index]
        else:
            del table[where[1]]
    return problems


def _value(v: Any, where: str) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if not math.isfinite(v):
            raise SetupError(f"{where}: {v} cannot be written to a set-up file")
        return repr(v)
    if isinstance(v, str):
        return toml_string(v)
    if isinstance(v, list | tuple):
        return "[" + ", ".join(_value(x, where) for x in v) + "]"
    raise SetupError(f"{where}: a {type(v).__name__} cannot be written to a set-up file")


def setup_toml_text(data: dict[str, Any]) -> str:
    """A set-up structure (keys, then one ``[table]`` per sub-table) as TOML text that
    :func:`saved_runs.toml_file.read_toml` reads back to the same structure."""
    top = [f"{k} = {_value(v, k)}" for k, v in data.items() if not isinstance(v, dict)]
    lines = ["# guideway set-up (written by guideway tui; keys as in docs/setup-*.toml)", *top]
    for name, table in data.items():
        if not isinstance(table, dict):
            continue
        lines += ["", f"[{name}]"]
        for k, v in table.items():
            if isinstance(v, dict):
                raise SetupError(f"[{name}] {k}: nested tables are not part of a set-up file")
            lines.append(f"{k} = {_value(v, f'[{name}] {k}')}")
    return "\n".join(lines) + "\n"


def setup_toml_update(text: str | None, data: dict[str, Any]) -> str:
    """``text`` (a set-up file's TOML) with its values replaced by those of ``data``: every comment,
    blank line and key order stays; keys ``data`` no longer has are taken out, new ones added at the
    end of their table; a value that did not change keeps its spelling (``1800`` stays ``1800``, not
    ``1800.0``).  Without ``text`` (or when it is not TOML) the file is :func:`setup_toml_text`."""
    import tomlkit  # (only when saving: not before the first frame)
    from tomlkit.exceptions import TOMLKitError

    fresh = setup_toml_text(data)  # also refuses what cannot be written (nan, nested tables)
    if text is None:
        return fresh
    try:
        doc = tomlkit.parse(text)
    except TOMLKitError:
        return fresh

    def same(old: Any, new: Any) -> bool:
        old = old.unwrap() if hasattr(old, "unwrap") else old
        return type(old) is type(new) and old == new or (
            isinstance(old, int | float) and isinstance(new, int | float) and not isinstance(old, bool)
            and not isinstance(new, bool) and float(old) == float(new))

    def update(table: Any, values: dict[str, Any]) -> None:
        for key in [k for k in table if k not in values and not isinstance(table[k], dict)]:
            del table[key]
        for key, value in values.items():
            if isinstance(value, dict):
                continue
            if key not in table or not same(table[key], value):
                table[key] = value

    update(doc, data)
    for name, values in data.items():
        if not isinstance(values, dict):
            continue
        if name not in doc:
            doc.add(name, tomlkit.table())
        update(doc[name], values)
    for name in [k for k in doc if isinstance(doc[k], dict) and k not in data]:
        del doc[name]
    return tomlkit.dumps(doc)
