"""Straightness evaluation of a gauge-block run: decoupling + reference lines."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import pandas as pd

from .decoupling import decouple_first_order
from .geometry import BlockGeometry
from .reference_lines import LineFit, endpoint_line, least_squares_line

METHODS = ("first-order",)


@dataclass(frozen=True)
class StraightnessResult:
    """Profile plus the reference lines fitted to it."""

    method: str
    profile: pd.DataFrame
    lines: dict[str, LineFit] = field(default_factory=dict)

    def straightness_um(self) -> dict[str, float]:
        return {name: fit.straightness_um for name, fit in self.lines.items()}

    def to_dict(self) -> dict[str, Any]:
        """The JSON object ``guideway process --json`` prints."""
        return {
            "kind": "straightness",
            "method": self.method,
            "profile": [
                {"station": int(r.station), "x_mm": float(r.x_mm), "height_um": float(r.height_um)}
                for r in self.profile.itertuples(index=False)
            ],
            "straightness_um": self.straightness_um(),
        }


def evaluate_straightness(
    points: pd.DataFrame, geometry: BlockGeometry, *, method: str = "first-order"
) -> StraightnessResult:
    """Decouple the run and fit the end-point and least-squares reference lines."""
    if method not in METHODS:
        raise ValueError(f"unknown decoupling method {method!r}; choose one of {', '.join(METHODS)}")
    profile = decouple_first_order(points, geometry)
    x = profile["x_mm"].to_numpy()
    h = profile["height_um"].to_numpy()
    lines: dict[str, LineFit] = {}
    if len(profile) >= 2:
        lines["endpoint"] = endpoint_line(x, h)
        lines["least_squares"] = least_squares_line(x, h)
    return StraightnessResult(method=method, profile=profile, lines=lines)
