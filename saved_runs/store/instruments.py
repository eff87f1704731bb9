"""The calibrated instruments of a run: a set-up's ``[[instrument]]`` tables, validated, and read back
from run.json ``setup.instruments`` (docs/run-format.md, docs/certificate.md).

::

    [[instrument]]
    role = "laser interferometer"       # what it measured (free text)
    model = "XL-80"
    serial = "123456"
    certificate = "DKD-K-12345 2026-0815"   # number of its calibration certificate
    calibrated = 2026-03-02                 # TOML dates (no quotes)
    due = 2027-03-02

``role`` and ``model`` are required; the others are optional (a certificate states what is missing,
it invents nothing).  Dates are stored in run.json as ISO 8601 text (``"2027-03-02"``).
"""

from __future__ import annotations

import datetime
from typing import Any

from ..errors import RunFormatError, SetupError

TEXT_KEYS = ("role", "model", "serial", "certificate")
DATE_KEYS = ("calibrated", "due")
REQUIRED = ("role", "model")
MAX_INSTRUMENTS = 50


def _date(value: Any, where: str, stored: bool) -> str:
    """ISO text of a TOML date (``stored``: also its ISO text, as run.json keeps it)."""
    if isinstance(value, datetime.date) and not isinstance(value, datetime.datetime):
        return value.isoformat()
    if stored and isinstance(value, str):
        try:
            return datetime.date.fromisoformat(value).isoformat()
        except ValueError:
            pass
    raise SetupError(f"{where} must be a TOML date such as 2027-03-02 (no quotes, no time), got {value!r}")


def instrument_tables(data: Any, source: str, *, stored: bool = False) -> list[dict[str, str]]:
    """The validated ``[[instrument]]`` tables of a set-up (``[]`` when absent), JSON-ready: text keys
    as given, dates as ISO text.  ``stored``: re-validating run.json (dates already ISO text)."""
    if data is None:
        return []
    if not isinstance(data, list):
        raise SetupError(f"{source}: instrument must be an array of tables: write [[instrument]] (two brackets)")
    if len(data) > MAX_INSTRUMENTS:
        raise SetupError(f"{source}: {len(data)} [[instrument]] tables; at most {MAX_INSTRUMENTS}")
    out = []
    for n, table in enumerate(data, 1):
        where = f"{source}: [[instrument]] #{n}"
        if not isinstance(table, dict):
            raise SetupError(f"{where} must be a table")
        extra = sorted(set(table) - set(TEXT_KEYS) - set(DATE_KEYS))
        if extra:
            raise SetupError(f"{where}: unknown key {extra[0]!r}; use {', '.join(TEXT_KEYS + DATE_KEYS)}")
        item: dict[str, str] = {}
        for key in TEXT_KEYS:
            if key in table:
                v = table[key]
                if not isinstance(v, str) or not v.strip():
                    raise SetupError(f"{where} {key} must be a non-empty string, got {v!r}")
                item[key] = v.strip()
            elif key in REQUIRED:
                raise SetupError(f"{where} {key} is missing; add it (see docs/setup-positioning.toml)")
        for key in DATE_KEYS:
            if key in table:
                item[key] = _date(table[key], f"{where} {key}", stored)
        if "calibrated" in item and "due" in item and item["due"] < item["calibrated"]:
            raise SetupError(f"{where}: due {item['due']} is before calibrated {item['calibrated']}")
        out.append(item)
    return out


def run_instruments(meta: dict[str, Any], where: str = "run.json") -> list[dict[str, str]]:
    """The calibrated instruments run.json records (``setup.instruments``); ``[]`` for a run written
    before they existed or without any.  A malformed entry is a one-line :class:`RunFormatError`."""
    try:
        return instrument_tables((meta.get("setup") or {}).get("instruments"), f"{where} setup.instruments",
                                 stored=True)
    except SetupError as exc:
        raise RunFormatError(str(exc)) from None


def expired(instruments: list[dict[str, str]], run_date: datetime.date) -> dict[str, str] | None:
    """The first instrument whose calibration was due before ``run_date`` (None: none was)."""
    for item in instruments:
        due = item.get("due")
        if due is not None and datetime.date.fromisoformat(due) < run_date:
            return item
    return None
