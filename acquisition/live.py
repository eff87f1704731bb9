"""Live processing: an engine subscriber that turns every new straightness point
into a surface height while the run goes on (the default decoupling method of
processing.decoupling against the run's first point, so the live value is the
value ``guideway process`` reports), for the terminal log and the UI."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from processing.decoupling import CHANNEL_COLUMNS, DECOUPLERS, DEFAULT_METHOD, Channels, Setup
from processing.geometry import BlockGeometry

HeightCallback = Callable[[int, int, float], None]  # (pass, station, height_um)


class LiveProfile:
    """Subscriber keeping ``heights[(pass, station)]`` (um, relative to the first point).

    ``first`` is the run's first point when a resumed run starts (it is already on disk);
    ``first_step`` its first step's (station 1 of the forward pass), if that is on disk too.
    """

    def __init__(self, geometry: BlockGeometry, on_height: HeightCallback | None = None,
                 first: dict[str, Any] | None = None, first_step: dict[str, Any] | None = None) -> None:
        self.geometry = geometry
        self.on_height = on_height
        self.first = first
        self.first_step = first_step
        self.heights: dict[tuple[int, int], float] = {}
        self._setup = Setup.from_geometry(geometry)

    def __call__(self, name: str, doc: dict[str, Any]) -> None:
        if name == "event" and doc.get("stream", "primary") == "primary":
            row = doc["data"]
            if self.first is None:
                self.first = row
            key = (int(row.get("pass", 0)), int(row["station"]))
            if key == (0, int(self.first["station"]) + 1):
                self.first_step = row  # the datum pitch estimate of the exact method comes from it
            # processing.decoupling.decouple on these points, without building a DataFrame per point
            rows = [self.first] if self.first_step is None else [self.first, self.first_step]
            rows.append(row)
            channels = Channels(**{f: np.array([r[f] for r in rows], dtype=float) for f in CHANNEL_COLUMNS},
                                first_step=None if self.first_step is None else 1)
            h = float(DECOUPLERS[DEFAULT_METHOD](channels, self._setup)[1][-1])
            self.heights[key] = h
            if self.on_height is not None:
                self.on_height(*key, h)
        elif name == "retract":
            m = doc["match"]
            key = (int(m.get("pass", 0)), int(m["station"]))
            self.heights.pop(key, None)
            if self.first is not None and key == (0, int(self.first["station"]) + 1):
                self.first_step = None
