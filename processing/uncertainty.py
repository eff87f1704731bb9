"""Measurement uncertainty of a straightness profile (GUM and GUM Supplement 1).

Inputs: the standard uncertainties (k = 1) of ``setup.uncertainty`` in run.json
(docs/run-format.md), :class:`UncertaintyInputs`.

Model.  Every output station's height is the mean over that station's points
of the point's decoupled height, and every point's height is its own channels
minus the datum point's (the first forward point).  So with weights w_kj
(1/n_k on the points of station k, -1 added on the datum point; the patent
method does not re-reference the interferometer channels, so for it the datum
weight of those is 0):

* independent per-point errors (sensor noise and resolution, interferometer
  straightness and angle noise, block placement along X):
  u^2 = sum_j w_kj^2 c_j^2 u^2;
* errors common to the whole run (each coordinate of P and Q):
  u^2 = (sum_j w_kj c_j)^2 u^2.

Sensitivity coefficients c are those of the first-order formula
h = stry + s + (xQ - xP) ez - (zQ - zP) ex, which are the exact method's to first
order (its own differ by terms of order angle x c): dh/dstry = 1, dh/ds = 1,
dh/dez = (xQ - xP), dh/dex = -(zQ - zP), dh/dxQ = -dh/dxP = ez_j,
dh/dzQ = -dh/dzP = -ex_j.  A position error dx of a point moves it along the
profile: dh = (local profile slope) dx, with u(dx) = step_mm for the methods
that use the nominal travel and position_um for ``exact`` (it measures x).
The exact method expresses the profile in the laser's fixed frame, so the
datum's own readings enter it like any other point's (no frame tilt).  Yaw,
strz and the y coordinates of P and Q enter only at second order, and so do
the datum block's angles in the laser frame: an error e0 of them moves a
height by at most |dR - I| |e0| (|v| + |yQ - yP|) (docs/conventions.md), below
1e-4 um for the estimated pitch's u (:func:`datum_pitch_u_urad`, ~1.4 urad) at
the angle changes of a guideway; the Monte Carlo re-estimates the pitch in
every trial, so it is in the straightness U all the same.

Monte Carlo (GUM-S1): the same input distributions (normal; the sensor
resolution uniform over one display step), seeded, drawn ``trials`` times;
each trial decouples with the selected method, averages the stations and
evaluates every reference line, vectorised over trials (the minimum zone by the
exact hulls of all trials at once, :func:`minimum_zone_many`).  The straightness uncertainty is the
standard deviation of the trial values; expanded U = k u with k = 2, and the
probabilistically symmetric 95 % coverage interval is given too.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import asdict, dataclass, fields
from typing import Any

import numpy as np

from .decoupling import DECOUPLERS, Channels, Setup
from .geometry import BlockGeometry
from .passes import StationGroups
from .point_columns import Points, as_columns, row_count
from .reference_lines import minimum_zone_many

K = 2.0


@dataclass(frozen=True)
class UncertaintyInputs:
    """Standard uncertainties (k = 1) of the inputs; defaults as in docs/run-format.md."""

    sensor_noise_um: float = 0.05
    sensor_resolution_um: float = 0.01
    straightness_um: float = 0.1
    angle_urad: float = 0.2
    position_um: float = 0.5
    offset_mm: float = 0.5
    step_mm: float = 0.05

    @staticmethod
    def from_dict(d: dict[str, Any] | None) -> UncertaintyInputs:
        """From run.json's ``setup.uncertainty`` (absent keys take the defaults)."""
        d = d or {}
        if not isinstance(d, dict):
            raise ValueError("setup.uncertainty must be an object")
        known = {f.name for f in fields(UncertaintyInputs)}
        unknown = sorted(set(d) - known)
        if unknown:
            raise ValueError(f"setup.uncertainty: unknown key(s) {', '.join(unknown)} "
                             f"(known: {', '.join(sorted(known))})")
        vals = {}
        for k, v in d.items():
            try:
                bad = isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v < 0
            except OverflowError:  # an int beyond a float's range (JSON digits): not a ValueError by itself
                raise ValueError(f"setup.uncertainty.{k} is too large a number ({len(str(abs(v)))} digits); "
                                 "give it in its unit (um, urad or mm)") from None
            if bad:
                raise ValueError(f"setup.uncertainty.{k} must be a non-negative number, got {v!r}")
            vals[k] = float(v)
        return UncertaintyInputs(**vals)

    def to_dict(self) -> dict[str, float]:
        return asdict(self)

    @property
    def sensor_um(self) -> float:
        """One averaged reading: noise and the display step (uniform, step/sqrt(12))."""
        return math.hypot(self.sensor_noise_um, self.sensor_resolution_um / math.sqrt(12.0))

    def x_um(self, method: str) -> float:
        return self.position_um if method == "exact" else self.step_mm * 1e3


def _datum_coefficient(groups: StationGroups, datum_weight: float, c: np.ndarray) -> np.ndarray:
    """Coefficient of the datum point (index 0) in each output station's height."""
    k0 = groups.group[0]
    coef = np.full(len(groups.stations), -datum_weight * c[0])
    coef[k0] += c[0] / groups.counts[k0]  # the datum is also one of its own station's points
    return coef


def _sum_sq(groups: StationGroups, datum_weight: float, c: np.ndarray) -> np.ndarray:
    """sum_j (w_kj c_j)^2 per output station: the station's own points get w = 1/n_k,
    the datum point its combined coefficient."""
    wc = c / groups.counts[groups.group]
    wc[0] = 0.0
    # minlength: every station has a point (its own group), so bincount's length is the stations' anyway
    own = np.bincount(groups.group, weights=wc**2, minlength=len(groups.stations))  # pragma: no mutate (equivalent)
    return own + _datum_coefficient(groups, datum_weight, c) ** 2


def _sum(groups: StationGroups, datum_weight: float, c: np.ndarray) -> np.ndarray:
    """sum_j w_kj c_j per output station."""
    wc = c / groups.counts[groups.group]
    wc[0] = 0.0
    own = np.bincount(groups.group, weights=wc, minlength=len(groups.stations))  # pragma: no mutate (equivalent)
    return own + _datum_coefficient(groups, datum_weight, c)


def profile_slope(x_mm: np.ndarray, h_um: np.ndarray) -> np.ndarray:
    """Local slope dh/dx (um/mm) of the profile (central differences, one-sided at the ends)."""
    if len(x_mm) < 2:
        return np.zeros(len(x_mm))
    return np.gradient(h_um, x_mm)


def datum_pitch_u_urad(ch: Channels, geometry: BlockGeometry, inputs: UncertaintyInputs) -> float | None:
    """Standard uncertainty (urad) of the datum pitch estimated from the first step (None without one).

    The estimate is the pitch of dR0^T (O1 - O0) (docs/conventions.md); to first
    order L times it is (stry1 - stry0) - (ez1 - ez0) xP + (ex1 - ex0) zP - ez0 L
    (two independent captures of each channel; xP and zP known to offset_mm), so
    u = sqrt(2 u_str^2 + (xP^2 + (xP - L)^2 + 2 zP^2) u_ang^2 + ...) / L.
    """
    i = ch.first_step
    if i is None:
        return None
    xp, _, zp = geometry.mirror_mm
    step_mm = float(ch.x_mm[i] - ch.x_mm[0])
    dez, dex = (float(a[i] - a[0]) * 1e-3 for a in (ch.pitch_urad, ch.roll_urad))
    lever_mm2 = xp**2 + (xp - step_mm) ** 2 + 2.0 * zp**2  # ez1: xP; ez0: xP - L (the chord turned back by ez0)
    var_um2 = (2.0 * inputs.straightness_um**2 + lever_mm2 * (inputs.angle_urad * 1e-3) ** 2
               + (dez**2 + dex**2) * inputs.offset_mm**2)
    return math.sqrt(var_um2) / abs(step_mm) * 1e3 if step_mm else None


def gum_per_station(points: Points, geometry: BlockGeometry, method: str, inputs: UncertaintyInputs,
                    groups: StationGroups, slope_um_per_mm: np.ndarray) -> np.ndarray:
    """Combined standard uncertainty u (um, k = 1) of each output station's height."""
    points = as_columns(points)
    n = row_count(points)
    xp, _, zp = geometry.mirror_mm
    xq, _, zq = geometry.sensor_mm
    ones = np.ones(n)
    ref = 0.0 if method == "patent" else 1.0  # interferometer channels re-referenced to the datum?
    var = _sum_sq(groups, 1.0, ones) * inputs.sensor_um**2
    var += _sum_sq(groups, ref, ones) * inputs.straightness_um**2
    var += _sum_sq(groups, ref, ones * (xq - xp) * 1e-3) * inputs.angle_urad**2
    var += _sum_sq(groups, ref, ones * (zq - zp) * 1e-3) * inputs.angle_urad**2
    ez = np.asarray(points["pitch_urad"], dtype=float) * 1e-3  # um per mm of offset
    ex = np.asarray(points["roll_urad"], dtype=float) * 1e-3
    var += 2 * _sum(groups, ref, ez) ** 2 * inputs.offset_mm**2  # xQ and xP
    var += 2 * _sum(groups, ref, ex) ** 2 * inputs.offset_mm**2  # zQ and zP
    var += slope_um_per_mm**2 * _sum_sq(groups, 1.0, ones) * (inputs.x_um(method) * 1e-3) ** 2
    return np.sqrt(var)


@dataclass(frozen=True)
class MonteCarloResult:
    trials: int
    seed: int
    per_station_std_um: np.ndarray
    straightness_um: dict[str, np.ndarray]  # trial values per reference line

    def summary(self) -> dict[str, dict[str, float]]:
        out = {}
        for name, v in self.straightness_um.items():
            lo, hi = np.percentile(v, [2.5, 97.5])
            out[name] = {"mean": float(v.mean()), "u": float(v.std(ddof=1)), "U": float(K * v.std(ddof=1)),
                         "interval_95": [float(lo), float(hi)]}
        return out


def _lines_vectorised(x: np.ndarray, h: np.ndarray, lines: tuple[str, ...]) -> dict[str, np.ndarray]:
    """Straightness per trial (rows of h) for each reference line.  Every row is computed on its own
    (no matrix product, whose rounding may depend on how many rows it is given), so a trial's values
    do not depend on the chunk it is evaluated in (nor on the memory order of ``h``: a row sum runs
    pairwise along a contiguous row, in sequence along a strided one)."""
    h = np.ascontiguousarray(h)
    out: dict[str, np.ndarray] = {}
    if "endpoint" in lines:
        b = (h[:, -1] - h[:, 0]) / (x[-1] - x[0])
        d = h - (h[:, :1] + b[:, None] * (x - x[0]))  # pragma: no mutate (equivalent: a shift of d keeps max - min)
        out["endpoint"] = d.max(axis=1) - d.min(axis=1)
    if "least_squares" in lines:
        xm = x - x.mean()
        b = (h * xm).sum(axis=1) / (xm @ xm)
        d = h - b[:, None] * xm
        out["least_squares"] = d.max(axis=1) - d.min(axis=1)
    if "minimum_zone" in lines:
        out["minimum_zone"] = minimum_zone_many(x, h)
    return out


# One random stream per input, so that trial t draws the same numbers however the trials are
# chunked: (offset: six numbers per trial, mirror x y z then sensor x y z).
MC_STREAMS: tuple[str, ...] = ("sensor_noise", "sensor_resolution", "stry", "strz", "pitch", "yaw", "roll",
                               "offset", "x")
# Trials x points evaluated at once.  The exact decoupling holds a few dozen temporaries of this
# size: 250 000 elements (2 MB each) keep the Monte Carlo's working set near 60 MB at any run size.
MC_CHUNK_ELEMENTS = 250_000


def mc_streams(seed: int) -> dict[str, np.random.Generator]:
    """The independent random streams of the Monte Carlo (one per input, :data:`MC_STREAMS`) of ``seed``."""
    children = np.random.SeedSequence(seed).spawn(len(MC_STREAMS))
    pairs = zip(MC_STREAMS, children, strict=True)  # pragma: no mutate (equivalent: the lengths are equal)
    return {name: np.random.default_rng(child) for name, child in pairs}


def mc_trial_heights(ch: Channels, setup: Setup, method: str, inputs: UncertaintyInputs, groups: StationGroups,
                     slope_um_per_mm: np.ndarray, streams: dict[str, np.random.Generator], m: int) -> np.ndarray:
    """The station heights (um, shape (m, stations)) of the next ``m`` trials drawn from ``streams``."""
    u, n = inputs, len(ch.x_mm)

    def noisy(a: np.ndarray, stream: str, sigma: float, scale: float = 1.0) -> np.ndarray:
        if sigma:  # pragma: no mutate (equivalent: a zero sigma would add exact zeros)
            return a + streams[stream].normal(0.0, sigma, (m, n)) * scale
        return np.broadcast_to(a, (m, n))

    sensor = noisy(ch.sensor_mm, "sensor_noise", u.sensor_noise_um, 1e-3)
    if u.sensor_resolution_um:
        sensor = sensor + streams["sensor_resolution"].uniform(-0.5, 0.5, (m, n)) * u.sensor_resolution_um * 1e-3
    chp = Channels(x_mm=ch.x_mm, lin_um=ch.lin_um, stry_um=noisy(ch.stry_um, "stry", u.straightness_um),
                   strz_um=noisy(ch.strz_um, "strz", u.straightness_um),
                   pitch_urad=noisy(ch.pitch_urad, "pitch", u.angle_urad),
                   yaw_urad=noisy(ch.yaw_urad, "yaw", u.angle_urad),
                   roll_urad=noisy(ch.roll_urad, "roll", u.angle_urad), sensor_mm=sensor, first_step=ch.first_step)
    off = streams["offset"].normal(0.0, u.offset_mm, (m, 6))
    coords = [v + off[:, i:i + 1] for i, v in enumerate((*setup.mirror, *setup.sensor))]
    sp = Setup(tuple(coords[:3]), tuple(coords[3:]), setup.beam, setup.sign, setup.datum_urad)  # type: ignore[arg-type]
    _, h = DECOUPLERS[method](chp, sp)
    dx = streams["x"].normal(0.0, u.x_um(method) * 1e-3, (m, n))
    dx -= dx[:, :1]
    return groups.average(h) + slope_um_per_mm * groups.average(dx)


def monte_carlo(points: Points, geometry: BlockGeometry, method: str, inputs: UncertaintyInputs,
                groups: StationGroups, x_out: np.ndarray, slope_um_per_mm: np.ndarray, *,
                trials: int = 10_000, seed: int = 0,
                lines: tuple[str, ...] = ("endpoint", "least_squares", "minimum_zone"),
                chunk_elements: int = MC_CHUNK_ELEMENTS,
                progress: Callable[[int, int], None] | None = None) -> MonteCarloResult:
    """Seeded Monte Carlo propagation (GUM-S1) through the selected decoupling method.

    ``progress(done, trials)`` is called after each chunk of trials (a front end's progress display).

    The trials are evaluated ``chunk_elements // points`` at a time (at least one): memory is
    bounded whatever the run's size, and the result does not depend on the chunking to the last
    digit (each input has its own stream, :func:`mc_streams`; each trial's straightness is computed
    on its own; the per-station sums run over the trials in order).  Per-station standard deviation
    from sums shifted by the first trial's heights (no cancellation: the shifted values are of the
    order of the scatter): s^2 = (sum d^2 - (sum d)^2 / N) / (N - 1), d = h - h_first.
    """
    if trials < 2:
        raise ValueError("Monte Carlo needs at least 2 trials")
    streams = mc_streams(seed)
    ch = Channels.from_points(points)
    setup = Setup.from_geometry(geometry)
    m_chunk = max(1, chunk_elements // max(len(ch.x_mm), 1))
    per_line = {name: np.empty(trials) for name in lines}
    shift: np.ndarray | None = None
    s1 = s2 = np.zeros(len(x_out))
    done = 0
    while done < trials:
        m = min(m_chunk, trials - done)
        h = mc_trial_heights(ch, setup, method, inputs, groups, slope_um_per_mm, streams, m)
        for name, values in _lines_vectorised(x_out, h, lines).items():
            per_line[name][done:done + m] = values
        if shift is None:
            shift = h[0].copy()
        for row in h:  # in trial order: the sums do not depend on where the chunks end
            d = row - shift
            s1 = s1 + d  # pragma: no mutate (equivalent: only s1 squared is used, and -s1 is exact)
            s2 = s2 + d * d
        done += m
        if progress is not None:
            progress(done, trials)
    var = (s2 - s1 * s1 / trials) / (trials - 1)
    return MonteCarloResult(trials, seed, np.sqrt(np.maximum(var, 0.0)), per_line)
