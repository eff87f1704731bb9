"""Live processing: an engine subscriber that turns every new straightness point
into a surface height while the run goes on (the default decoupling method of
processing.decoupling against the run's first point, so the live value is the
value ``guideway process`` reports), for the terminal log and the UI."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from processing.decoupling import DECOUPLERS, DEFAULT_METHOD, Channels, Setup
from processing.geometry import BlockGeometry

HeightCallback = Callable[[int, int, float], None]  # (pass, station, height_um)


class LiveProfile:
    """Subscriber keeping ``heights[(pass, station)]`` (um, relative to the first point).

    ``first`` is the run's first point when a resumed run starts (it is already on disk).
    """

    def __init__(self, geometry: BlockGeometry, on_height: HeightCallback | None = None,
                 first: dict[str, Any] | None = None) -> None:
        self.geometry = geometry
        self.on_height = on_height
        self.first = first
        self.heights: dict[tuple[int, int], float] = {}
        self._setup = Setup.from_geometry(geometry)

    def __call__(self, name: str, doc: dict[str, Any]) -> None:
        if name == "event" and doc.get("stream", "primary") == "primary":
            row = doc["data"]
            if self.first is None:
                self.first = row
            # processing.decoupling.decouple on the two points, without building a DataFrame per point
            first = self.first
            channels = Channels(**{f: np.array([first[f], row[f]], dtype=float) for f in Channels.__dataclass_fields__})
            h = float(DECOUPLERS[DEFAULT_METHOD](channels, self._setup)[1][-1])
            key = (int(row.get("pass", 0)), int(row["station"]))
            self.heights[key] = h
            if self.on_height is not None:
                self.on_height(*key, h)
        elif name == "retract":
            m = doc["match"]
            self.heights.pop((int(m.get("pass", 0)), int(m["station"])), None)
