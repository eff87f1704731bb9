"""saved_runs/store/fixed_csv.py against Python's own ``"%.6f" % value`` (the C library's correctly
rounded conversion), value by value, including the cases a digit-by-digit formatter gets wrong:
exact ties (half to even on the binary value), negative zero and negatives that round to zero,
carries into a new integer digit, large magnitudes, NaN and infinities."""

from __future__ import annotations

import numpy as np
import pytest

from saved_runs.store.fixed_csv import fixed_csv


def python_csv(columns: list[str], data: np.ndarray, decimals: int) -> str:
    lines = [",".join(columns)]
    for row in data.tolist():
        lines.append(",".join("" if v != v else f"{v:.{decimals}f}" for v in row))
    return "\n".join(lines) + "\n"


HARD = [0.0, -0.0, 0.5e-6, 1.5e-6, 2.5e-6, -0.5e-6, -1e-9, 1e-9, 0.9999995, 9.9999995, 99.9999996,
        -99.9999996, 0.1234565, 2.675, 1234567.0000005, 41.9275, -489.795918367, 1e11 + 0.5e-6, 5e-7,
        4.9999999e-7, 123456.1234565]


@pytest.mark.parametrize("decimals", [6, 3, 0])
def test_hard_values_are_formatted_as_python_does(decimals: int) -> None:
    data = np.array(HARD, dtype=float).reshape(-1, 1)
    assert fixed_csv(["v"], data, decimals) == python_csv(["v"], data, decimals)


def test_random_tables_match_python_formatting_byte_for_byte() -> None:
    rng = np.random.default_rng(7)
    n = 5000
    data = np.column_stack([
        rng.normal(0.0, 50.0, n), rng.uniform(-1200.0, 1200.0, n), np.round(rng.normal(0.0, 5.0, n), 7),
        rng.normal(0.0, 1e-7, n), rng.choice(HARD, n), rng.normal(0.0, 1e5, n), np.zeros(n),
    ])
    cols = [f"c{i}_um" for i in range(data.shape[1])]
    assert fixed_csv(cols, data) == python_csv(cols, data, 6)


def test_values_beyond_exact_scaling_and_non_finite_values_fall_back_to_python() -> None:
    data = np.array([[1e13, np.nan], [-3.25e15, np.inf], [2.0, -np.inf]])
    assert fixed_csv(["big", "odd"], data) == python_csv(["big", "odd"], data, 6)


def test_empty_table_is_the_header_and_a_wrong_shape_is_refused() -> None:
    assert fixed_csv(["a", "b"], np.zeros((0, 2))) == "a,b\n"
    with pytest.raises(ValueError, match="does not match 3 columns"):
        fixed_csv(["a", "b", "c"], np.zeros((2, 2)))
