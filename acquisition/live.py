"""Live processing: engine subscribers that evaluate every new point while the run goes on,
with the code ``guideway process`` uses, for the terminal log and the UI:

* :class:`LiveProfile` (straightness): the surface height of each station (the default
  decoupling method of processing.decoupling against the run's first point);
* :class:`LiveDeviation` (positioning): the deviation actual − target of each point after the
  environmental compensation of processing.environment (the air index of the run's first point
  as the datum index, as ``process`` takes it), so a raw reading that carries the air index and
  the material expansion (hundreds of µm over a metre) is not shown as a deviation."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from drivers.readings import AveragedDisplacement, InterferometerReading
from processing.decoupling import CHANNEL_COLUMNS, DECOUPLERS, DEFAULT_METHOD, Channels, Setup
from processing.environment import EnvironmentSettings, angular_deviation_deg, compensate_linear_readings
from processing.geometry import BlockGeometry

from .plans.straightness import point_record

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

    def _height(self, row: dict[str, Any]) -> float:
        """processing.decoupling.decouple of ``row`` against the first point (and the first step), without
        building a DataFrame per point."""
        assert self.first is not None
        rows = [self.first] if self.first_step is None else [self.first, self.first_step]
        rows.append(row)
        channels = Channels(**{f: np.array([r[f] for r in rows], dtype=float) for f in CHANNEL_COLUMNS},
                            first_step=None if self.first_step is None else 1)
        return float(DECOUPLERS[DEFAULT_METHOD](channels, self._setup)[1][-1])

    def height_now(self, row: dict[str, Any]) -> float:
        """The surface height (µm) a capture of ``row`` (a points.csv row built from a live reading,
        :func:`live_row`) would give now; nothing is kept.  NaN before the run's first point."""
        if self.first is None:
            return float("nan")
        return self._height(row)

    def __call__(self, name: str, doc: dict[str, Any]) -> None:
        if name == "event" and doc.get("stream", "primary") == "primary":
            row = doc["data"]
            if self.first is None:
                self.first = row
            key = (int(row.get("pass", 0)), int(row["station"]))
            if key == (0, int(self.first["station"]) + 1):
                self.first_step = row  # the datum pitch estimate of the exact method comes from it
            h = self._height(row)
            self.heights[key] = h
            if self.on_height is not None:
                self.on_height(*key, h)
        elif name == "retract":
            m = doc["match"]
            key = (int(m.get("pass", 0)), int(m["station"]))
            self.heights.pop(key, None)
            if self.first is not None and key == (0, int(self.first["station"]) + 1):
                self.first_step = None


def live_row(ifm: InterferometerReading, sensor_mm: float, station: int, x_mm: float, pass_: int = 0
             ) -> dict[str, Any]:
    """A straightness points.csv row from a live look at the devices (the plan's ``point_record`` with the
    live sensor value in place of the averaged one), for :meth:`LiveProfile.height_now`."""
    sensor = AveragedDisplacement(sensor_mm, 0.0, 1, 0, ifm.timestamp_s)
    return point_record(station, x_mm, ifm.timestamp_s, ifm, sensor, pass_)


DeviationCallback = Callable[[dict[str, Any], float, str], None]  # (row, deviation, label)
ENVIRONMENT_COLUMNS = ("reading_mm", "air_temp_c", "air_pressure_hpa", "humidity_pct", "material_temp_c")
ARCSEC_PER_DEG = 3600.0
UM_PER_MM = 1000.0


class LiveDeviation:
    """Subscriber keeping ``deviations[(run, direction, target_index)]`` of a positioning run:
    µm after environmental compensation (linear axes), arcsec (rotary axes, not air-compensated,
    as ``process``).  ``label`` says which; ``first`` is the run's first point when a resumed run
    starts.  A point the compensation cannot use (a missing air value) gets NaN and ``label``
    says why."""

    def __init__(self, axis_type: str, environment: dict[str, Any] | None,
                 on_deviation: DeviationCallback | None = None, first: dict[str, Any] | None = None) -> None:
        self.rotary = axis_type == "rotary"
        self.settings = EnvironmentSettings.from_dict(environment)
        self.on_deviation = on_deviation
        self.first = first
        self.unit = "arcsec" if self.rotary else "um"
        self.deviations: dict[tuple[int, int, int], float] = {}
        if self.rotary:
            self.label = "angular, not air-compensated"
        elif self.settings.readings_compensated:
            self.label = "readings compensated by the controller"
        else:
            self.label = "environment-compensated"

    def deviation(self, row: dict[str, Any]) -> tuple[float, str]:
        """(deviation, label) of one points.csv row (see the class)."""
        if self.rotary:
            return float(angular_deviation_deg(row["reading_deg"], row["target_deg"])) * ARCSEC_PER_DEG, self.label
        first = self.first if self.first is not None else row
        cols = [np.array([float(first.get(c, np.nan)), float(row.get(c, np.nan))]) for c in ENVIRONMENT_COLUMNS]
        try:
            length, _ = compensate_linear_readings(*cols, self.settings)
        except ValueError as exc:
            return float("nan"), f"not compensated: {exc}"
        return (float(length[-1]) - float(row["target_mm"])) * UM_PER_MM, self.label

    def deviation_now(self, ifm: InterferometerReading, reading: float, target: float) -> tuple[float, str]:
        """(deviation, label) of the axis now: a live capture ``ifm`` with ``reading`` (the datum plus the
        interferometer position or angle, mm or deg) against ``target``, compensated as a captured point
        would be (the air index of the run's first point; before it, of this reading)."""
        unit = "deg" if self.rotary else "mm"
        row = {f"reading_{unit}": reading, f"target_{unit}": target, "air_temp_c": ifm.air_temp_c,
               "air_pressure_hpa": ifm.air_pressure_hpa, "humidity_pct": ifm.humidity_pct,
               "material_temp_c": ifm.material_temp_c}
        return self.deviation(row)

    def __call__(self, name: str, doc: dict[str, Any]) -> None:
        if name != "event" or doc.get("stream", "primary") != "primary":
            return
        row = doc["data"]
        if self.first is None:
            self.first = row
        value, label = self.deviation(row)
        self.deviations[(int(row["run"]), int(row["direction"]), int(row["target_index"]))] = value
        if self.on_deviation is not None:
            self.on_deviation(row, value, label)
