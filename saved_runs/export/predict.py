"""The as-left run a table predicts: the as-found run's deviations with the table applied as its controller
applies it (docs/compensation.md, "Verify").

At every measured point of the as-found run (each run, each direction) the correction c(P_i, direction) of
the table is added, the table read with the settings the as-left run recorded (run.json ``compensation``:
COMP_FILE_TYPE, Fanuc reference position and detection unit, backlash parameter): x_pred = x_found + c.
When the as-found run was itself measured with a table active, that table's correction is taken out first
(x_found − c_old + c_new, CARTO's rule).  The ISO 230-2 values of x_pred are the export's "as written"
figures for every value (E, M, B, R, A per direction), not only E and M.  Positions mm (deg), deviations um
(arcsec).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from processing.iso230_2 import Iso2302Result, evaluate_iso230_2

from ..errors import UserError
from ..evaluation.positioning import PositioningEvaluation
from ..store.compensation import compensation_text, run_compensation
from .carto import ActiveTable, load_recorded_table

ERROR_SCALE = {"linear": 1000.0, "rotary": 3600.0}  # um per mm, arcsec per deg


@dataclass(frozen=True)
class Prediction:
    """``deviations``: the as-found points with the table applied; ``result`` their ISO 230-2 evaluation
    (same k and edition as the as-found run's); ``notes`` what the prediction assumed."""

    deviations: pd.DataFrame
    result: Iso2302Result
    notes: tuple[str, ...]


def table_correction(found: PositioningEvaluation, record: dict, what: str) -> np.ndarray:
    """The correction (um or arcsec) the recorded table makes at every as-found point."""
    table = load_recorded_table(record, found.run.meta, what, "the prediction applies it to the as-found run")
    dev = found.deviations
    active = ActiveTable(record, table)
    scale = ERROR_SCALE[found.result.axis_type]
    return active.correction(dev["target"].to_numpy(float), dev["direction"].to_numpy(int), scale)


def predict_as_left(found: PositioningEvaluation, left_record: dict) -> Prediction:
    """The as-found run with the as-left run's table applied (module docstring).  ``left_record``: the
    as-left run's run.json ``compensation`` (active).  One-line :class:`UserError` when a table file is
    missing, changed or unreadable."""
    notes = []
    dev = found.deviations.copy()
    values = dev["deviation"].to_numpy(float)
    old = run_compensation(found.run.meta)
    if old.get("active"):
        if old.get("sha256") == left_record.get("sha256"):
            raise UserError("AS_FOUND and AS_LEFT were measured with the same table active "
                            f"({compensation_text(old).removeprefix('controller compensation: ')}): nothing was "
                            "changed between them; verify a run measured with the new table")
        values = values - table_correction(found, old, "the table active during AS_FOUND")
        notes.append("AS_FOUND was measured with a table active: the prediction takes its correction out and puts "
                     "the new table's in (CARTO's rule)")
    elif old.get("active") is None:
        notes.append("AS_FOUND does not record whether a table was active while it was measured: the prediction "
                     "takes it as measured without one")
    dev["deviation"] = values + table_correction(found, left_record, "the table active during AS_LEFT")
    r = found.result
    return Prediction(dev, evaluate_iso230_2(dev, axis_type=r.axis_type, k=r.k, edition=r.edition), tuple(notes))
