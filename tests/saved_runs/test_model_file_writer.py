"""The model-file writer (saved_runs/diagnosis/model_file.py) keeps every float as TOML reads it back:
+inf and -inf as TOML's ``inf`` and ``-inf``, not as ``nan`` (issue 25)."""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

import pytest

from processing.effects import Effect
from saved_runs.diagnosis.model_file import commented_effect, load_model, model_toml
from saved_runs.errors import SetupError
from saved_runs.toml_file import read_toml

# Written here, not taken from the code: what the file must hold after a read.
VALUES = (math.inf, -math.inf, math.nan, 1.5, -0.25, 1e300)


def _table() -> Effect:
    # Built directly (make_effect refuses non-finite values): the writer must still write what it is given.
    return Effect("error_table", {"positions_mm": (0.0, 100.0, 200.0, 300.0, 400.0, 500.0), "error_um": VALUES})


def _same(read: list[float]) -> None:
    assert len(read) == len(VALUES)
    for got, want in zip(read, VALUES, strict=True):
        if math.isnan(want):
            assert math.isnan(got)
        else:
            assert got == want and math.copysign(1.0, got) == math.copysign(1.0, want)


def test_infinities_round_trip_through_a_model_file(tmp_path: Path) -> None:
    path = tmp_path / "model.toml"
    path.write_text(model_toml("positioning", [(_table(), "a table with infinite values")], ["test"]),
                    encoding="utf-8")
    data = read_toml(path)
    _same(data["effect"][0]["error_um"])
    # and the reader refuses such a model with a one-line error rather than fitting with nan
    with pytest.raises(SetupError, match="error_um must be a list of numbers"):
        load_model(path)


def test_infinities_round_trip_through_a_commented_effect() -> None:
    lines = commented_effect(Effect("linear_scale", {"ppm": -math.inf}))
    assert tomllib.loads("\n".join(lines))["effect"][0]["ppm"] == -math.inf
    _same(tomllib.loads("\n".join(commented_effect(_table())))["effect"][0]["error_um"])
