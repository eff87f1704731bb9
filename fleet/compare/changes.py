"""The arithmetic of a change between two runs, shared by both run kinds.

The change of a value is b − a (run B minus run A: after − before).  Its expanded uncertainty is
U = k · √(u_a² + u_b²): the two runs are independent measurements, so their standard uncertainties add
in quadrature (GUM 5.1.2 with both sensitivities ±1 and no correlation).  A change is significant when
|b − a| > U; when U cannot be evaluated, significance is ``None`` (unknown), never ``False``."""

from __future__ import annotations

import math


def finite(value: float | None) -> bool:
    return value is not None and math.isfinite(value)


def change(a: float | None, b: float | None) -> float | None:
    """b − a, or None when either is missing or not finite."""
    return b - a if finite(a) and finite(b) else None  # type: ignore[operator]


def change_pct(a: float | None, b: float | None) -> float | None:
    """(b − a) / |a| · 100 %, or None when a is 0 or either is missing (|a| keeps the sign of the change
    for a signed value such as the mean reversal B̄)."""
    d = change(a, b)
    return None if d is None or a == 0 else 100.0 * d / abs(a)  # type: ignore[arg-type]


def combined_expanded(u_a: float | None, u_b: float | None, k: float) -> float | None:
    """U = k · √(u_a² + u_b²) of a difference of two independent values (standard uncertainties u_a, u_b)."""
    return k * math.hypot(u_a, u_b) if finite(u_a) and finite(u_b) else None  # type: ignore[arg-type]


def significant(delta: float | None, expanded: float | None) -> bool | None:
    """|delta| > U, or None when either is unknown."""
    return None if delta is None or expanded is None else abs(delta) > expanded


def none_if_nan(value: float | None) -> float | None:
    return value if finite(value) else None
