"""Serial correlation of a channel's errors: the AR(1) coefficient of the residual in time order,
the Prais–Winsten transform that whitens it (feasible GLS) and the Ljung–Box test of whiteness.

Real calibration data drift slowly with the air and the machine's temperature, so successive
errors are correlated: e_t = φ e_{t−1} + w_t (w white).  Ordinary least squares then takes a slow
wander for a trend and its F-test is far too optimistic.  The diagnosis estimates φ from the
residual of the larger model of each test (consistent under both hypotheses), removes the bias a
fitted model leaves in the lag-1 autocorrelation of its residual by matching moments, and compares
the nested models' residual sums of squares after the transform
z₀ = √(1 − φ²) v₀, z_t = v_t − φ v_{t−1} (rows in time order), under which the errors are white.

One run of a few hundred points fixes φ only to about √((1 − φ²)/n) (0.03 at φ 0.9, n 210), which
moves a slow effect's test statistic by ±30 %: no test on one run both holds its false alarms on every
machine with φ up to 0.98 and detects a 5-standard-error drift 9 times in 10 at φ 0.9 (a Neyman–Pearson
bound, docs/diagnosis.md, "Under correlated noise").
Earlier runs of the same machine fix it better: their estimates (:class:`Ar1Estimate`, converted to
this run's point interval) are pooled with this run's (:func:`ar1_coefficient` ``history``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import optimize, signal, stats

PHI_MAX = 0.98  # beyond this a run holds too few independent errors to say anything
# φ̂ is used only when the correlation is detectable (one-sided 1 % test of φ = 0, SE of φ̂ ≈ 1/√n): whitening
# for a φ that is not there costs a slow effect's test (1 − φ)/√(1 + φ²) of its signal-to-noise ratio
PHI_Z = 2.33


def time_order(values: dict[str, np.ndarray], n: int) -> np.ndarray:
    """Indices of the points in time order (acquisition order where no time is recorded)."""
    t = values.get("time_min")
    if t is None or len(t) != n or not np.all(np.isfinite(t)):
        return np.arange(n)
    return np.argsort(t, kind="stable")


def lag1(r: np.ndarray) -> float:
    """Lag-1 autocorrelation Σ r_t r_{t+1} / Σ r_t² of a sequence (already in order)."""
    den = float(r @ r)
    return float(r[1:] @ r[:-1]) / den if den > 0 else 0.0


def r_times(q: np.ndarray, phi: float) -> np.ndarray:
    """R(φ) q with R_ij = φ^|i−j| (rows in order), by a forward and a backward recursion."""
    fwd = signal.lfilter([1.0], [1.0, -phi], q, axis=0)
    bwd = signal.lfilter([1.0], [1.0, -phi], q[::-1], axis=0)[::-1]
    return fwd + bwd - q


def _half_shift(v: np.ndarray) -> np.ndarray:
    """A v with vᵀ A v = Σ v_t v_{t+1} (A: ½ on the first off-diagonals)."""
    out = np.zeros_like(v)
    out[1:] = v[:-1] / 2
    out[:-1] += v[1:] / 2
    return out


def expected_lag1(q: np.ndarray, phi: float) -> float:
    """E[Σ e_t e_{t+1}] / E[Σ e_t²] for e = M u, M = I − QQᵀ the residual maker of the fitted
    design (``q``: its orthonormal basis, rows in order) and u AR(1) with coefficient φ:
    tr(M A M R) / tr(M R) = ((n−1)φ − 2 tr(QᵀARQ) + tr(QᵀAQ · QᵀRQ)) / (n − tr(QᵀRQ))."""
    n = q.shape[0]
    rq = r_times(q, phi)
    qrq = q.T @ rq
    num = (n - 1) * phi - 2.0 * float(np.sum(_half_shift(q) * rq)) + float(np.sum((q.T @ _half_shift(q)) * qrq.T))
    den = n - float(np.trace(qrq))
    return num / den if den > 0 else 0.0


@dataclass(frozen=True)
class Ar1Estimate:
    """The bias-corrected AR(1) coefficient of one earlier run's errors in time order."""

    phi: float  # not clipped at 0 nor gated, so that pooled estimates stay unbiased
    n: int  # points it rests on
    interval_s: float | None  # median time between successive points (None: no time recorded)
    source: str = ""  # the run it comes from

    def at_interval(self, interval_s: float | None) -> float:
        """φ for points ``interval_s`` apart: errors that decay as e^(−Δt/τ) have φ = e^(−Δt/τ) per point, so
        φ' = φ^(Δt'/Δt).  Unchanged when either interval is unknown or φ ≤ 0 (no decay time to scale)."""
        if self.phi <= 0.0 or not interval_s or not self.interval_s:
            return self.phi
        return min(self.phi ** (interval_s / self.interval_s), PHI_MAX)

    def to_dict(self) -> dict[str, object]:
        return {"run": self.source, "phi": self.phi, "points": self.n, "interval_s": self.interval_s}


def point_interval_s(time_min: np.ndarray | None) -> float | None:
    """Median time between successive points (s), from their times (min); None without times."""
    if time_min is None or len(time_min) < 2 or not np.all(np.isfinite(time_min)):
        return None
    step = float(np.median(np.diff(np.sort(time_min)))) * 60.0
    return step if step > 0 else None


def matched_phi(residual_ordered: np.ndarray, basis_ordered: np.ndarray, low: float = -PHI_MAX) -> float:
    """The φ whose expected residual lag-1 autocorrelation (:func:`expected_lag1`) equals the observed one,
    within [``low``, PHI_MAX]; nan when it lies below ``low``."""
    r1 = lag1(residual_ordered)

    def gap(phi: float) -> float:
        return expected_lag1(basis_ordered, phi) - r1

    if low >= PHI_MAX or gap(low) >= 0:
        return math.nan
    # fixed point φ ← φ − gap(φ): the expectation's slope in φ is close to 1 (the bias is O(p / n)), so a few
    # steps reach 1e-3, at a fraction of a bracketing search's evaluations on a long run
    phi = min(max(r1, low), PHI_MAX)
    for _ in range(6):
        step = gap(phi)
        phi = min(max(phi - step, low), PHI_MAX)
        if abs(step) < 1e-3:
            return phi
    # a short run or many fitted columns: the slope is far from 1 (0.34 at 10 points, 3 columns) and the fixed
    # point still 0.04 away after 6 steps; the root is bracketed (gap(low) < 0), so a bracketing search ends it
    if gap(PHI_MAX) <= 0:
        return PHI_MAX
    return float(optimize.brentq(gap, low, PHI_MAX))


def ar1_coefficient(residual_ordered: np.ndarray, basis_ordered: np.ndarray,
                    history: tuple[Ar1Estimate, ...] = (), interval_s: float | None = None) -> float:
    """The AR(1) coefficient of the errors behind a least-squares residual (both in time order),
    bias-corrected (:func:`matched_phi`); clipped to [0, PHI_MAX] (a negative φ is taken as none: the tests
    stay those for independent errors, which are then conservative), and 0 unless φ̂·√n > PHI_Z.

    ``history``: estimates from earlier runs of the same machine, pooled with this run's by their points
    (each converted to this run's point interval ``interval_s``, s); the gate then counts all their points."""
    n = len(residual_ordered)
    if n < 8 and not history:
        return 0.0
    if not history:
        phi = matched_phi(residual_ordered, basis_ordered, low=PHI_Z / math.sqrt(n))
        return 0.0 if math.isnan(phi) else phi
    own = matched_phi(residual_ordered, basis_ordered) if n >= 8 else math.nan
    pairs = [(e.at_interval(interval_s), e.n) for e in history] + [(own, n)]
    pairs = [(phi, m) for phi, m in pairs if not math.isnan(phi)]  # own: nan under 8 points or below -PHI_MAX
    total = sum(m for _, m in pairs)
    if total == 0:
        return 0.0
    phi = sum(phi * m for phi, m in pairs) / total
    return min(phi, PHI_MAX) if phi * math.sqrt(total) > PHI_Z else 0.0


def prais_winsten(v: np.ndarray, order: np.ndarray, phi: float) -> np.ndarray:
    """Rows of ``v`` (1-D or 2-D, in the points' order) whitened for AR(1) errors in ``order``:
    z₀ = √(1 − φ²) v₀, z_t = v_t − φ v_{t−1}; returned in time order."""
    s = v[order]
    if phi == 0.0:
        return s
    out = s.copy()
    out[0] = math.sqrt(1.0 - phi * phi) * s[0]
    out[1:] = s[1:] - phi * s[:-1]
    return out


def ljung_box(r: np.ndarray, lags: int, fitted: int = 0) -> tuple[float, float, int]:
    """Ljung–Box portmanteau test of a sequence (in order): Q = n(n+2) Σ_{k≤h} ρ_k² / (n−k) against
    χ² with h − ``fitted`` degrees of freedom (at least 1); (Q, p, h)."""
    n = len(r)
    h = max(1, min(lags, n // 4))
    r = r - r.mean()
    den = float(r @ r)
    if n < 8 or den <= 0:
        return 0.0, 1.0, h
    rho = np.array([float(r[k:] @ r[:-k]) / den for k in range(1, h + 1)])
    q = float(n * (n + 2) * np.sum(rho**2 / (n - np.arange(1, h + 1))))
    return q, float(stats.chi2.sf(q, max(h - fitted, 1))), h
