"""Which catalogue is configured, without importing SQLAlchemy: the runs browser and the end of an
acquisition ask this first and open the database only when one is named (docs/fleet.md)."""

from __future__ import annotations

import os

ENV_VAR = "GUIDEWAY_CATALOG"


def configured_url(given: str | None = None) -> str | None:
    """The catalogue named by ``given`` (``--catalog`` or a set-up's ``[catalog] url``) or by the
    ``GUIDEWAY_CATALOG`` environment variable; None when neither names one."""
    for url in (given, os.environ.get(ENV_VAR)):
        if url and url.strip():
            return url.strip()
    return None
