"""A run's points as processing takes them: a mapping of column name -> 1-D numpy array (what
``saved_runs`` reads, without pandas) or a pandas DataFrame (tests, callers that built one).  The
columns and their units: :mod:`processing.columns`."""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any, TypeAlias

import numpy as np

if TYPE_CHECKING:
    import pandas as pd

Points: TypeAlias = "Mapping[str, np.ndarray] | pd.DataFrame"


def as_columns(points: Points) -> dict[str, np.ndarray]:
    """``points`` as a dict name -> 1-D array (no copy of a mapping's arrays)."""
    if isinstance(points, Mapping):
        return {str(k): np.asarray(v) for k, v in points.items()}
    return {str(c): points[c].to_numpy() for c in points.columns}


def row_count(points: Mapping[str, Any]) -> int:
    """The number of rows of a mapping of equal-length columns (0 without columns)."""
    return len(next(iter(points.values()), ()))
