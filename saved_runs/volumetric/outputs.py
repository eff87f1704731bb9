"""Files of ``guideway volumetric MACHINE.toml --out DIR`` (docs/volumetric.md, "Output"):

* ``volumetric.csv`` — one row per grid pose: axis positions (``X_mm`` … ``C_deg``), the error
  ``dx_um, dy_um, dz_um``, ``d_um`` = |d| and ``ex_urad, ey_urad, ez_urad``;
* ``contributions.csv`` — the same poses, the first-order contribution of every group (an axis's
  motion and location errors, ``squareness``, ``thermal``) as ``<group>_dx_um`` …;
* ``summary.json`` — extremes with their poses, RMS, contributions, element ranking, notes;
* ``report.html`` — the printable report with the error-field plots.

Each file is replaced atomically.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from ..errors import UserError
from ..store.files import write_json_atomic, write_text_atomic
from ..store.fixed_csv import fixed_csv
from ..store.stale_temps import remove_own_stale_temps
from .field import FieldResult, field_summary

FILES = ("volumetric.csv", "contributions.csv", "summary.json", "report.html")


def write_field(result: FieldResult, out_dir: Path | str, *, command: str = "",
                progress: Callable[[int, int], None] | None = None) -> dict[str, Any]:
    """Write the four files into ``out_dir`` (created if needed); return the summary object.
    ``progress(done, 4)`` after each file (a front end's progress display)."""

    def written(name: str) -> None:
        if progress is not None:
            progress(FILES.index(name) + 1, len(FILES))

    from .report import volumetric_page  # matplotlib only when writing

    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise UserError(f"--out {out} exists and is not a directory; choose another --out")
    try:
        out.mkdir(parents=True, exist_ok=True)
        remove_own_stale_temps(out, FILES)  # what a killed grid writer left
        summary = field_summary(result)
        for name, table in (("volumetric.csv", result.table()), ("contributions.csv", result.contribution_table())):
            # the text of to_csv(float_format="%.6f"), formatted on whole arrays (a --grid 50 has 4.4 M values)
            write_text_atomic(out / name, fixed_csv(list(table.columns), table.to_numpy(dtype=float)), inside=out)
            written(name)
        # inside=out: a link planted at one of the tool's names in the folder is refused, not replaced
        write_json_atomic(out / "summary.json", summary, inside=out)
        written("summary.json")
        write_text_atomic(out / "report.html", volumetric_page(result, summary, command).render(), inside=out)
        written("report.html")
    except OSError as exc:
        raise UserError(f"cannot write the results to {out}: {exc.strerror or exc}") from None
    return summary
