"""The simulated physical world: a guideway, a gauge block resting on it and
the instruments' view of that block.

Geometry (docs/conventions.md): X = travel, Y = up, Z = X x Y; rotations
R = Rz(ez) Ry(ey) Rx(ex).  The block frame has its origin at the rear, bottom,
centre of the block.  The block rests on three pads (rear-left, rear-right,
front-centre) on the guideway base surface and is pressed against the side
face at two points (rear and front); its pose is solved exactly (Newton on the
six contact equations with their analytic Jacobian), with no small-angle
approximation.

The interferometer measures in the laser's fixed frame (its beam along the
laser's X; :class:`Laser` is its alignment in the world).  It is zeroed with
the block at the datum pose and then reports, in that frame, the displacement
of the mirror point P since the datum and the rotation of the block since the
datum (R_now R_datum^T, as Z-Y-X angles); the datum block itself stands tilted
in the laser frame by the local slope under it (``datum_angles_urad``).  The
displacement sensor is a head at point E on the block, reading along the beam
direction b (block frame); its reading is the distance from E to where the beam
meets the surface.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Wave:
    """One sinusoidal component: amplitude (um), wavelength (mm), phase (rad)."""

    amplitude_um: float
    wavelength_mm: float
    phase_rad: float = 0.0


@dataclass(frozen=True)
class Guideway:
    """Base surface height y(x, z) and side face z(x), in mm.

    y(x, z) = sum of waves(x) + slope*x + (twist0 + twist_rate*x)*z
    side(x) = sum of side waves(x): deviation of the side face in Z.
    """

    waves: tuple[Wave, ...] = (Wave(3.0, 640.0, 0.3), Wave(0.8, 230.0, 1.7))
    slope_urad: float = 4.0
    twist0_urad: float = 5.0
    twist_urad_per_m: float = 20.0
    side_waves: tuple[Wave, ...] = (Wave(2.0, 900.0, 0.5),)

    @staticmethod
    def from_seed(seed: int) -> Guideway:
        """The default guideway with wave phases drawn from ``seed`` (a different surface per seed)."""
        rng = np.random.default_rng([seed, 7])
        base = Guideway()
        return Guideway(
            waves=tuple(Wave(w.amplitude_um, w.wavelength_mm, float(rng.uniform(0, 2 * math.pi)))
                        for w in base.waves),
            slope_urad=base.slope_urad,
            twist0_urad=base.twist0_urad,
            twist_urad_per_m=base.twist_urad_per_m,
            side_waves=tuple(Wave(w.amplitude_um, w.wavelength_mm, float(rng.uniform(0, 2 * math.pi)))
                             for w in base.side_waves),
        )

    def height_mm(self, x_mm: float, z_mm: float) -> float:
        y = self.slope_urad * 1e-6 * x_mm
        for w in self.waves:
            y += w.amplitude_um * 1e-3 * math.sin(2 * math.pi * x_mm / w.wavelength_mm + w.phase_rad)
        return y + self.transverse_slope(x_mm) * z_mm

    def transverse_slope(self, x_mm: float) -> float:
        """dy/dz of the base surface at x (rad)."""
        return (self.twist0_urad + self.twist_urad_per_m * x_mm / 1000.0) * 1e-6

    def height_slope(self, x_mm: float, z_mm: float) -> tuple[float, float]:
        """Partial derivatives (dy/dx, dy/dz) of the base surface."""
        dx = self.slope_urad * 1e-6 + self.twist_urad_per_m * 1e-9 * z_mm
        for w in self.waves:
            k = 2 * math.pi / w.wavelength_mm
            dx += w.amplitude_um * 1e-3 * k * math.cos(k * x_mm + w.phase_rad)
        return dx, self.transverse_slope(x_mm)

    def side_mm(self, x_mm: float) -> float:
        z = 0.0
        for w in self.side_waves:
            z += w.amplitude_um * 1e-3 * math.sin(2 * math.pi * x_mm / w.wavelength_mm + w.phase_rad)
        return z


@dataclass(frozen=True)
class BlockSetup:
    """Gauge block and what is mounted on it, in the block frame (mm).

    ``mirror_mm`` is the interferometer's measuring point P; ``sensor_head_mm``
    the displacement sensor's reference point E; ``beam`` the unit beam
    direction; ``standoff_mm`` the sensor's reference distance (reading 0).
    """

    length_mm: float = 100.0
    width_mm: float = 35.0
    side_contact_height_mm: float = 4.0
    mirror_mm: tuple[float, float, float] = (50.0, 110.0, 0.0)
    sensor_head_mm: tuple[float, float, float] = (150.0, 30.0, 40.0)
    beam: tuple[float, float, float] = (0.0, -1.0, 0.0)
    standoff_mm: float = 30.0


@dataclass(frozen=True)
class Noise:
    """Standard deviations of the instrument noise (0 switches a term off)."""

    sensor_um: float = 0.05
    straightness_um: float = 0.05
    position_um: float = 0.05
    angle_urad: float = 0.1
    placement_um: float = 20.0

    @staticmethod
    def off() -> Noise:
        return Noise(0.0, 0.0, 0.0, 0.0, 0.0)


@dataclass(frozen=True)
class Laser:
    """Alignment of the laser in the world: its axes are the world's rotated by
    R = Rz(pitch) Ry(yaw) Rx(roll) (urad); its beam runs along its own X."""

    roll_urad: float = 0.0
    yaw_urad: float = 0.0
    pitch_urad: float = 0.0

    def rotation(self) -> np.ndarray:
        return rotation(self.roll_urad * 1e-6, self.yaw_urad * 1e-6, self.pitch_urad * 1e-6)


@dataclass(frozen=True)
class Environment:
    """Air and material conditions (slow linear drift per hour)."""

    air_temp_c: float = 20.4
    air_pressure_hpa: float = 1012.8
    humidity_pct: float = 45.0
    material_temp_c: float = 20.2
    drift_c_per_h: float = 0.05


def rot_x(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def rot_y(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def rot_z(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def rotation(ex: float, ey: float, ez: float) -> np.ndarray:
    """R = Rz(ez) Ry(ey) Rx(ex)."""
    return rot_z(ez) @ rot_y(ey) @ rot_x(ex)


def _rotation_and_derivatives(ex: float, ey: float, ez: float) -> tuple[np.ndarray, np.ndarray]:
    """R = Rz(ez) Ry(ey) Rx(ex) and its partial derivatives dR/d(ex, ey, ez) stacked (3, 3, 3)."""
    rx, ry, rz = rot_x(ex), rot_y(ey), rot_z(ez)
    cx, sx = math.cos(ex), math.sin(ex)
    cy, sy = math.cos(ey), math.sin(ey)
    cz, sz = math.cos(ez), math.sin(ez)
    drx = np.array([[0, 0, 0], [0, -sx, -cx], [0, cx, -sx]])
    dry = np.array([[-sy, 0, cy], [0, 0, 0], [-cy, 0, -sy]])
    drz = np.array([[-sz, -cz, 0], [cz, -sz, 0], [0, 0, 0]])
    rzy = rz @ ry
    return rzy @ rx, np.stack((rzy @ drx, rz @ dry @ rx, drz @ ry @ rx))


def _side_slope(g: Guideway, x_mm: float) -> float:
    """d side(x) / dx of the side face (rad)."""
    dz = 0.0
    for w in g.side_waves:
        k = 2 * math.pi / w.wavelength_mm
        dz += w.amplitude_um * 1e-3 * k * math.cos(k * x_mm + w.phase_rad)
    return dz


def euler_zyx(r: np.ndarray) -> tuple[float, float, float]:
    """(ex, ey, ez) with r = Rz(ez) Ry(ey) Rx(ex)."""
    ey = -math.asin(max(-1.0, min(1.0, r[2, 0])))
    ex = math.atan2(r[2, 1], r[2, 2])
    ez = math.atan2(r[1, 0], r[0, 0])
    return ex, ey, ez


@dataclass
class Pose:
    """Block pose in the world: p_world = R @ p_block + t."""

    r: np.ndarray
    t: np.ndarray

    def apply(self, p: tuple[float, float, float] | np.ndarray) -> np.ndarray:
        return self.r @ np.asarray(p, dtype=float) + self.t


@dataclass
class Capture:
    """What the interferometer reports: P displacement and block rotation since the datum, laser frame."""

    position_mm: float
    stry_um: float
    strz_um: float
    pitch_urad: float
    yaw_urad: float
    roll_urad: float


class World:
    """Shared simulated state; thread-safe (emulators run in their own threads)."""

    def __init__(
        self,
        *,
        guideway: Guideway | None = None,
        block: BlockSetup | None = None,
        noise: Noise | None = None,
        environment: Environment | None = None,
        laser: Laser | None = None,
        seed: int = 0,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.guideway = guideway or Guideway.from_seed(seed)
        self.laser = laser or Laser()
        self._laser_r = self.laser.rotation()  # laser axes in the world (columns)
        self.block = block or BlockSetup()
        self.noise = noise if noise is not None else Noise()
        self.environment = environment or Environment()
        self._rng = np.random.default_rng(seed)
        self._clock = clock
        self._t0 = self._clock()
        self._lock = threading.RLock()
        self.station = 0
        self.beam_blocked = False
        self._pose = self.solve_pose(0.0)
        self._datum = self._pose
        self.sample_log: list[tuple[int, np.ndarray]] = []
        self._hit_cache: tuple[Pose, Guideway, BlockSetup, float, np.ndarray] | None = None

    # -- kinematics ---------------------------------------------------------------------
    def solve_pose(self, x_rear_mm: float) -> Pose:
        """Exact resting pose with the block's rear end at world x = ``x_rear_mm``.

        Newton on the six contact equations (three pads on the base surface, two
        side contacts, the rear end's x) with their analytic Jacobian.
        """
        g, b = self.guideway, self.block
        half = b.width_mm / 2
        # contact points (block frame, one per column): three pads, then two side contacts
        pts = np.array([[0.0, 0.0, b.length_mm, 0.0, b.length_mm],
                        [0.0, 0.0, 0.0, b.side_contact_height_mm, b.side_contact_height_mm],
                        [-half, half, 0.0, -half, -half]])
        u = np.array([0.0, 0.0, 0.0, x_rear_mm, g.height_mm(x_rear_mm, 0.0), 0.0])
        f = np.empty(6)
        jac = np.zeros((6, 6))
        jac[5, 3] = 1.0  # the rear-end constraint t_x = x_rear
        for _ in range(30):
            r, dr = _rotation_and_derivatives(u[0], u[1], u[2])
            t = u[3:]
            w = (r @ pts).T + t  # world contact points, one per row
            dw = dr @ pts  # dw[j, :, i]: d(contact i) / d(angle j)
            for i in range(3):  # pads: w_y - h(w_x, w_z)
                x, z = float(w[i, 0]), float(w[i, 2])
                hx, hz = g.height_slope(x, z)
                f[i] = w[i, 1] - g.height_mm(x, z)
                jac[i, :3] = dw[:, 1, i] - hx * dw[:, 0, i] - hz * dw[:, 2, i]
                jac[i, 3:] = (-hx, 1.0, -hz)
            for i in (3, 4):  # side contacts: w_z - side(w_x)
                x = float(w[i, 0])
                sx = _side_slope(g, x)
                f[i] = w[i, 2] - (-half + g.side_mm(x))
                jac[i, :3] = dw[:, 2, i] - sx * dw[:, 0, i]
                jac[i, 3:] = (-sx, 0.0, 1.0)
            f[5] = t[0] - x_rear_mm
            if np.max(np.abs(f)) < 1e-13:
                break
            u = u - np.linalg.solve(jac, f)
        else:  # pragma: no cover - the contact problem is well conditioned
            raise RuntimeError("block pose did not converge")
        return Pose(r, t.copy())

    def beam_hit(self, pose: Pose) -> tuple[float, np.ndarray]:
        """(distance from E along the beam, world point) where the beam meets the surface."""
        g, b = self.guideway, self.block
        e = pose.apply(b.sensor_head_mm)
        d = pose.r @ np.asarray(b.beam, dtype=float)
        lam = (e[1] - g.height_mm(e[0], e[2])) / -d[1]
        for _ in range(50):
            p = e + lam * d
            f = p[1] - g.height_mm(p[0], p[2])
            sx, sz = g.height_slope(p[0], p[2])
            df = d[1] - sx * d[0] - sz * d[2]
            step = f / df
            lam -= step
            if abs(step) < 1e-13:  # 1e-7 nm; smaller steps only chase the rounding of p[1] (~30 mm terms)
                break
        return lam, e + lam * d

    # -- operations (called by the simulated technician and the emulators) ------------
    def nominal_x_mm(self, station: int) -> float:
        return station * self.block.length_mm

    def place_block(self, station: int, offset_mm: float = 0.0) -> None:
        """The simulated technician puts the block at ``station`` (with placement scatter);
        ``offset_mm``: still ``offset_mm`` short of it (sliding it there)."""
        with self._lock:
            err_mm = self._rng.normal(0.0, self.noise.placement_um) * 1e-3 if self.noise.placement_um else 0.0
            self.station = station
            self._pose = self.solve_pose(self.nominal_x_mm(station) + err_mm + offset_mm)

    def set_datum(self) -> None:
        """Zero the interferometer at the current pose."""
        with self._lock:
            self._datum = self._pose

    @property
    def pose(self) -> Pose:
        with self._lock:
            return self._pose

    def _n(self, sigma: float) -> float:
        return float(self._rng.normal(0.0, sigma)) if sigma else 0.0

    def capture(self) -> Capture:
        """Interferometer view of the current pose (with noise)."""
        with self._lock:
            pose, datum, lr = self._pose, self._datum, self._laser_r
            p = np.asarray(self.block.mirror_mm, dtype=float)
            d = lr.T @ (pose.apply(p) - datum.apply(p))  # in the laser frame
            ex, ey, ez = euler_zyx(lr.T @ pose.r @ datum.r.T @ lr)  # rotation since the datum, laser frame
            n = self.noise
            return Capture(
                position_mm=float(d[0]) + self._n(n.position_um) * 1e-3,
                stry_um=float(d[1]) * 1e3 + self._n(n.straightness_um),
                strz_um=float(d[2]) * 1e3 + self._n(n.straightness_um),
                pitch_urad=ez * 1e6 + self._n(n.angle_urad),
                yaw_urad=ey * 1e6 + self._n(n.angle_urad),
                roll_urad=ex * 1e6 + self._n(n.angle_urad),
            )

    def sensor_distance_mm(self) -> float | None:
        """Beam length from E to the surface (with noise); None if the beam is blocked."""
        with self._lock:
            if self.beam_blocked:
                return None
            lam, hit = self._current_beam_hit()
            self.sample_log.append((self.station, hit))
            return lam + self._n(self.noise.sensor_um) * 1e-3

    def _current_beam_hit(self) -> tuple[float, np.ndarray]:
        """beam_hit of the current pose, solved once per placement (every sample of a reading needs it)."""
        pose, g, b = self._pose, self.guideway, self.block
        c = self._hit_cache
        if c is None or c[0] is not pose or c[1] is not g or c[2] is not b:
            lam, hit = self.beam_hit(pose)
            hit.flags.writeable = False  # shared by the sample log entries of this placement
            c = self._hit_cache = (pose, g, b, lam, hit)
        return c[3], c[4]

    def environment_now(self) -> tuple[float, float, float, float]:
        """(air temp C, pressure hPa, humidity %RH, material temp C)."""
        with self._lock:
            env = self.environment
            hours = (self._clock() - self._t0) / 3600.0
            drift = env.drift_c_per_h * hours
            return (
                env.air_temp_c + drift + self._n(0.002),
                env.air_pressure_hpa + self._n(0.01),
                env.humidity_pct + self._n(0.05),
                env.material_temp_c + 0.5 * drift + self._n(0.002),
            )

    # -- ground truth for tests and diagnosis --------------------------------------------
    def datum_angles_urad(self) -> dict[str, float]:
        """The datum block's angles in the laser frame (what a set-up's ``datum_angles_urad`` measures)."""
        with self._lock:
            ex, ey, ez = euler_zyx(self._laser_r.T @ self._datum.r)
            return {"roll": ex * 1e6, "yaw": ey * 1e6, "pitch": ez * 1e6}

    def in_laser_frame(self, v: np.ndarray) -> np.ndarray:
        """A world vector expressed in the laser frame."""
        return self._laser_r.T @ np.asarray(v, dtype=float)

    def true_sample_point(self, station: int) -> np.ndarray:
        """World point where the beam meets the surface with the block at ``station``
        (as last placed, if it is the current station; else a fresh exact placement)."""
        with self._lock:
            pose = self._pose if station == self.station else self.solve_pose(self.nominal_x_mm(station))
            return self.beam_hit(pose)[1]
