"""Which catalogue is configured, without importing SQLAlchemy: the runs browser and the end of an
acquisition ask this first and open the database only when one is named (docs/fleet.md).

A catalogue URL may hold a password (``postgresql://USER:PASSWORD@HOST/DB``, or ``?password=`` in its
query).  It is never shown (:func:`masked_url`: SQLAlchemy's ``***`` form) nor stored
(:func:`url_without_password`: run.json keeps the URL without it; libpq then takes the password from
``~/.pgpass``, ``PGPASSWORD`` or a service file)."""

from __future__ import annotations

import os
import re

ENV_VAR = "GUIDEWAY_CATALOG"
HIDDEN = "***"  # what SQLAlchemy's URL.render_as_string(hide_password=True) shows for a password

_SCHEME = re.compile(r"^(?P<scheme>[\w+.-]+://)(?P<rest>.*)$", re.S)
_QUERY_PASSWORD = re.compile(r"(?i)(^|&)(password=)[^&]*")


def configured_url(given: str | None = None) -> str | None:
    """The catalogue named by ``given`` (``--catalog`` or a set-up's ``[catalog] url``) or by the
    ``GUIDEWAY_CATALOG`` environment variable; None when neither names one."""
    for url in (given, os.environ.get(ENV_VAR)):
        if url and url.strip():
            return url.strip()
    return None


def _split(url: str) -> tuple[str, str | None, str, str] | None:
    """``url`` as (scheme://, user:password part or None, host/database part, ?query part); None when it
    is no ``scheme://`` URL.  The user part ends at the last ``@`` before the query, so that a password
    holding an unescaped ``@`` is hidden whole (SQLAlchemy would cut it at its first ``@``)."""
    m = _SCHEME.match(url)
    if m is None:
        return None
    rest = m["rest"]
    head, sep, query = rest.partition("?")
    userinfo, at, hostpart = head.rpartition("@")
    return m["scheme"], (userinfo if at else None), (hostpart if at else head), sep + query


def _hide_query(query: str, replacement: str | None) -> str:
    """``?...`` with its ``password=`` parameters replaced by ``password=REPLACEMENT`` (None: left out)."""
    if not query:
        return query
    body = query[1:]
    if replacement is None:
        kept = [p for p in body.split("&") if not p.lower().startswith("password=")]
        return "?" + "&".join(kept) if kept else ""
    return "?" + _QUERY_PASSWORD.sub(lambda m: m[1] + m[2] + replacement, body)


def masked_url(url: str) -> str:
    """``url`` as it may be shown: its password as ``***`` (the form of ``guideway catalog`` messages)."""
    parts = _split(url)
    if parts is None:
        return url
    scheme, userinfo, hostpart, query = parts
    if userinfo is not None and ":" in userinfo:
        userinfo = userinfo.split(":", 1)[0] + ":" + HIDDEN
    return scheme + (f"{userinfo}@" if userinfo is not None else "") + hostpart + _hide_query(query, HIDDEN)


def url_without_password(url: str) -> str:
    """``url`` as it may be stored (run.json): without its password, which libpq then takes from
    ``~/.pgpass``, ``PGPASSWORD`` or a service file."""
    parts = _split(url)
    if parts is None:
        return url
    scheme, userinfo, hostpart, query = parts
    if userinfo is not None:
        userinfo = userinfo.split(":", 1)[0]
    return scheme + (f"{userinfo}@" if userinfo else "") + hostpart + _hide_query(query, None)
