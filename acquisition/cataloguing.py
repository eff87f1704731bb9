"""A completed run adds itself to the catalogue when one is configured: the set-up's ``[catalog] url``,
else the ``GUIDEWAY_CATALOG`` environment variable (docs/fleet.md).  Never the default file on its own:
a rig that has not asked for a catalogue gets none.  A catalogue that cannot be reached costs a note,
never the run (it is on disk; ``guideway catalog add RUN`` adds it later)."""

from __future__ import annotations

from pathlib import Path
from typing import Any, TextIO

from saved_runs.errors import UserError


def setup_catalog_url(source: dict[str, Any] | None) -> str | None:
    """``[catalog] url`` of a set-up's TOML structure (checked by the set-up loaders), None when absent."""
    table = (source or {}).get("catalog")
    url = table.get("url") if isinstance(table, dict) else None
    return url if isinstance(url, str) and url.strip() else None


def storable_setup_source(source: dict[str, Any] | None) -> dict[str, Any] | None:
    """A set-up's TOML structure as run.json keeps it (``setup_source``): its ``[catalog] url`` without a
    password (run directories are archived and handed on; the password stays in ``~/.pgpass``,
    ``PGPASSWORD`` or the set-up file)."""
    url = setup_catalog_url(source)
    if source is None or url is None:
        return source
    from fleet.catalog.config import url_without_password

    return {**source, "catalog": {**source["catalog"], "url": url_without_password(url)}}


def add_completed_run(run_dir: Path | str, setup_url: str | None, stream: TextIO) -> str | None:
    """Add ``run_dir`` to the configured catalogue; return the one line printed on ``stream`` (None: no
    catalogue configured)."""
    from fleet.catalog.config import configured_url

    url = configured_url(setup_url)
    if url is None:
        return None
    try:
        from fleet.catalog.database import open_catalog
        from fleet.catalog.runs import add_runs

        with open_catalog(url) as cat:
            outcomes = list(add_runs(cat, [run_dir]))
            line = f"catalogue {cat.url}: {outcomes[0].message}"
    except UserError as exc:
        line = (f"note: the run was not added to the catalogue ({exc}); add it later with: "
                f"guideway catalog add {run_dir}")
    print(line, file=stream)
    return line
