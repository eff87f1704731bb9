"""Least-squares fit of a model (a list of effects) to one observed channel, with the
statistics the selection rule needs: residual sum of squares, parameter count, standard
errors, the information criterion and grouped cross-validation.

Columns are scaled to unit norm before every solve (positions in mm, times in minutes and
index changes of 1e-6 differ by many orders of magnitude).  A periodic effect with a free
wavelength is fitted by variable projection: for each trial wavelength the rest of the model
is linear, so the residual sum of squares is a function of the wavelength alone; it is
scanned on a frequency grid (5 points per cycle-per-span) and refined by Brent's method.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import optimize

from ..effects import Effect
from . import basis, serial
from .observations import Observations

RANK_RTOL = 1e-6  # columns (unit norm) closer to collinear than this count as dependent
OVERSAMPLE = 5


@dataclass(frozen=True)
class Fit:
    """A model fitted to one channel: the effects with their fitted values and what is left."""

    effects: tuple[Effect, ...]
    residual: np.ndarray
    rss: float
    n_params: int  # rank of the linear design plus the free wavelengths
    design: np.ndarray  # nuisance and free columns at the fitted wavelengths
    target: np.ndarray  # the observations minus the fixed contributions
    se: tuple[dict[str, float | tuple[float, ...]], ...]  # standard error of every free parameter
    # the AR(1) coefficient of the errors in time order the standard errors are corrected for (0: independent)
    se_ar1_phi: float = 0.0

    @property
    def n(self) -> int:
        return len(self.residual)

    @property
    def rms_um(self) -> float:
        return float(np.sqrt(self.rss / self.n)) if self.n else math.nan

    @property
    def max_um(self) -> float:
        return float(np.max(np.abs(self.residual))) if self.n else math.nan

    @property
    def sigma_um(self) -> float:
        """Residual standard error sqrt(RSS / (n − p))."""
        dof = self.n - self.n_params
        return float(np.sqrt(self.rss / dof)) if dof > 0 else math.nan


def _scaled(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    norms = np.sqrt(np.einsum("ij,ij->j", x, x))
    norms[norms == 0] = 1.0
    return x / norms, norms


def _eig(gram: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Eigenpairs of a scaled Gram matrix above the rank threshold (RANK_RTOL² of the largest)."""
    w, v = np.linalg.eigh(gram)
    keep = w > max(w[-1], 0.0) * RANK_RTOL**2 if w.size else np.zeros(0, dtype=bool)
    return w[keep], v[:, keep]


def solve(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, float, int]:
    """Least squares on scaled columns by the normal equations (pseudo-inverse: minimum-norm where
    columns are collinear): (coefficients, RSS, rank)."""
    xs, norms = _scaled(x)
    w, v = _eig(xs.T @ xs)
    coef = (v @ ((v.T @ (xs.T @ y)) / w)) / norms
    r = y - x @ coef
    return coef, float(r @ r), int(w.size)


def orthonormal_basis(x: np.ndarray) -> np.ndarray:
    """An orthonormal basis (n × rank) of the column space of ``x``."""
    xs, _ = _scaled(x)
    w, v = _eig(xs.T @ xs)
    return (xs @ v) / np.sqrt(w)


def fixed_part(effects: tuple[Effect, ...], obs: Observations) -> np.ndarray:
    total = np.zeros(obs.n)
    for e in effects:
        if not e.free:
            total += basis.value(e, obs)
    return total


def _design(effects: tuple[Effect, ...], obs: Observations, wavelengths: dict[int, float],
            skip: set[int] | frozenset[int] = frozenset()) -> tuple[np.ndarray, list[tuple[int, basis.Columns]]]:
    blocks = [obs.nuisance]
    cols = []
    for i, e in enumerate(effects):
        if e.free and i not in skip:
            c = basis.columns(e, obs, wavelengths.get(i))
            cols.append((i, c))
            blocks.append(c.matrix)
    return np.column_stack(blocks), cols


# -- periodic wavelength search ----------------------------------------------------------------------
def wavelength_grid(positions_mm: np.ndarray) -> tuple[np.ndarray, float]:
    """Trial wavelengths (mm) and the number of independent ones M for a positioning channel.

    From twice the median spacing of the distinct positions (shorter ones alias) up to the span
    (one full period inside the travel), evenly in frequency with ``OVERSAMPLE`` points per
    1/span; M = span / λ_min − 1 (at least 1) is the look-elsewhere factor of the p-value.
    """
    u = np.unique(positions_mm)
    if len(u) < 4:
        return np.empty(0), 1.0
    span = float(u[-1] - u[0])
    lam_min = 2.0 * float(np.median(np.diff(u)))
    f = np.arange(1.0 / span, 1.0 / lam_min + 1e-15, 1.0 / (OVERSAMPLE * span))
    return 1.0 / f, max(1.0, span / lam_min - 1.0)


class _Scan:
    """RSS of (base design + a sine/cosine pair) as a function of the wavelength, fast: the base's
    column space is projected out once, and the sums run over distinct positions."""

    def __init__(self, base: np.ndarray, y: np.ndarray, positions: np.ndarray) -> None:
        u = orthonormal_basis(base)
        self.r0 = y - u @ (u.T @ y)
        self.rss0 = float(self.r0 @ self.r0)
        self.pos, inv = np.unique(positions, return_inverse=True)
        self.count = np.bincount(inv, minlength=len(self.pos)).astype(float)
        self.r_agg = np.bincount(inv, weights=self.r0, minlength=len(self.pos))
        self.u_agg = np.column_stack([np.bincount(inv, weights=col, minlength=len(self.pos)) for col in u.T]) \
            if u.shape[1] else np.zeros((len(self.pos), 0))

    def rss(self, wavelengths: np.ndarray) -> np.ndarray:
        th = 2 * np.pi * self.pos[:, None] / np.asarray(wavelengths, dtype=float)[None, :]
        s, c = np.sin(th), np.cos(th)
        us, uc = self.u_agg.T @ s, self.u_agg.T @ c
        gss = self.count @ (s * s) - np.sum(us * us, axis=0)
        gcc = self.count @ (c * c) - np.sum(uc * uc, axis=0)
        gsc = self.count @ (s * c) - np.sum(us * uc, axis=0)
        a, b = self.r_agg @ s, self.r_agg @ c
        det = gss * gcc - gsc**2
        ok = det > 1e-12 * np.maximum(gss * gcc, 1e-300)
        gain = np.where(ok, (gcc * a * a - 2 * gsc * a * b + gss * b * b) / np.where(ok, det, 1.0), 0.0)
        return self.rss0 - gain

    def best(self, grid: np.ndarray, around: float | None = None, avoid: tuple[float, ...] = ()) -> float:
        """The wavelength of least RSS: over ``grid``, or refined near ``around``; at least one frequency
        resolution (1 / span) from the wavelengths in ``avoid`` (the model's other periodic effects: two
        periods the travel cannot tell apart are one period, and a nearly equal pair with huge opposite
        amplitudes would mimic any P·cos shape)."""
        span = float(self.pos[-1] - self.pos[0]) or 1.0
        taken = np.array([1.0 / w for w in avoid])
        if around is None:
            free = grid[np.all(np.abs(1.0 / grid[:, None] - taken[None, :]) >= 1.0 / span, axis=1)] \
                if taken.size else grid
            if free.size == 0:
                raise ValueError("no wavelength left that the travel can tell apart from the model's periodic effects")
            rss = np.concatenate([self.rss(chunk) for chunk in np.array_split(free, max(1, len(free) // 256))])
            f0 = 1.0 / free[int(np.argmin(rss))]
        else:
            f0 = 1.0 / around
        df = 1.0 / (OVERSAMPLE * span)
        lo, hi = max(f0 - df, 1.0 / span), f0 + df  # one full period inside the travel, as the grid
        for f in taken:  # keep the refinement on f0's side of every other period, a resolution away
            if f <= f0:
                lo = max(lo, min(f + 1.0 / span, f0))
            else:
                hi = min(hi, max(f - 1.0 / span, f0))
        if hi - lo <= df * 1e-4:
            return 1.0 / f0
        res = optimize.minimize_scalar(lambda f: float(self.rss(np.array([1.0 / f]))[0]), bounds=(lo, hi),
                                       method="bounded", options={"xatol": df * 1e-4})
        trial = np.array([f0, float(res.x)])
        return float(1.0 / trial[int(np.argmin(self.rss(1.0 / trial)))])


def free_wavelength(e: Effect) -> bool:
    return e.type == "periodic" and "wavelength_mm" in e.free


# -- the fit ---------------------------------------------------------------------------------------------
def fit_model(obs: Observations, effects: tuple[Effect, ...] | list[Effect], *,
              refine: set[int] | None = None, standard_errors: bool = True,
              ar1_history: tuple[serial.Ar1Estimate, ...] | None = None) -> Fit:
    """Fit the free parameters of ``effects`` (and the nuisance) to ``obs``.

    A free-wavelength periodic effect without a wavelength is searched over :func:`wavelength_grid`,
    one with a wavelength (a start value, or the last fit's) is refined near it; ``refine``: only those
    effects' wavelengths are searched or refined, the others are used as they are (a candidate tested
    against a fitted model).  ``standard_errors=False`` skips them (candidate tests).  With ``ar1_history``
    (a tuple, possibly empty: the earlier runs' estimates) the standard errors are those of the fitted values
    under AR(1) errors in time order, φ estimated from the fit's residual as the tests estimate it
    (:func:`serial.ar1_coefficient`); None: the ordinary ones, for independent errors.
    """
    effects = tuple(effects)
    target = obs.y_um - fixed_part(effects, obs)
    nonlinear = [i for i, e in enumerate(effects) if free_wavelength(e)]
    wl: dict[int, float] = {}
    for i in nonlinear:
        start = effects[i].params.get("wavelength_mm")
        if start is not None:
            wl[i] = float(start)  # type: ignore[arg-type]
    searched = [i for i in nonlinear if refine is None or i in refine]
    grid, _ = wavelength_grid(obs.values["position_mm"]) if searched else (np.empty(0), 1.0)
    for _sweep in range(2 if len(searched) > 1 else 1):
        for i in searched:
            if i not in wl and len(grid) == 0:
                raise ValueError("a periodic wavelength cannot be searched with fewer than 4 distinct positions")
            unknown = {j for j in nonlinear if j not in wl}
            base, _ = _design(effects, obs, wl, skip=unknown | {i})
            scan = _Scan(base, target, obs.values["position_mm"])
            others = tuple(wl[j] for j in nonlinear if j != i and j in wl) + tuple(
                float(e.params["wavelength_mm"]) for j, e in enumerate(effects)  # type: ignore[arg-type]
                if j not in nonlinear and e.type == "periodic" and e.params.get("wavelength_mm") is not None)
            wl[i] = scan.best(grid, around=wl.get(i), avoid=others)
    x, cols = _design(effects, obs, wl)
    coef, rss, rank = solve(x, target)
    fitted = list(effects)
    pos = obs.nuisance.shape[1]
    for i, c in cols:
        k = c.matrix.shape[1]
        block = coef[pos:pos + k]
        if effects[i].type in basis.TABLES:
            block = table_gauge(c.matrix, obs.nuisance, block)
        fitted[i] = effects[i].with_params(c.to_params(block))
        pos += k
    residual = target - x @ coef
    n_params = rank + len(nonlinear)
    phi = 0.0
    if standard_errors and ar1_history is not None:
        order = serial.time_order(obs.values, obs.n)
        phi = serial.ar1_coefficient(residual[order], orthonormal_basis(x)[order], ar1_history,
                                     serial.point_interval_s(obs.values.get("time_min")))
    ar1 = None
    if phi > 0.0:
        # the marginal σ² of AR(1) errors by the moments φ̂ is matched with (serial.expected_lag1): the residual
        # e = M u has E[eᵀe] = σ² tr(MR) = σ² (n − tr(QᵀRQ)), Q an orthonormal basis of the design in time order
        q = orthonormal_basis(x)[order]
        left = obs.n - float(np.sum(q * serial.r_times(q, phi)))
        if left > 0:
            ar1 = (order, phi, rss / left)
        else:
            phi = 0.0
    se = _standard_errors(obs, tuple(fitted), rss, n_params, ar1) if standard_errors else tuple({} for _ in fitted)
    return Fit(tuple(fitted), residual, rss, n_params, x, target, se, phi)


def without_nuisance(cols: np.ndarray, nuisance: np.ndarray) -> np.ndarray:
    """``cols`` minus their least-squares projection on the nuisance columns."""
    u = orthonormal_basis(nuisance)
    return cols - u @ (u.T @ cols)


def table_gauge(hats: np.ndarray, nuisance: np.ndarray, values: np.ndarray) -> np.ndarray:
    """The values of a free table in its reported gauge.

    A table's level (and with a reference line its slope) is not separable from the nuisance: the
    values are reported with the part the nuisance can absorb removed, i.e. orthogonal to the value
    vectors w whose contribution lies in the nuisance's span (for an offset nuisance: zero sum).
    """
    h = without_nuisance(hats, nuisance)
    w, v = np.linalg.eigh(h.T @ h)
    null = v[:, w <= max(w[-1], 0.0) * RANK_RTOL**2] if w.size else np.zeros((len(values), 0))
    return values - null @ (null.T @ values)


def _standard_errors(obs: Observations, effects: tuple[Effect, ...], rss: float, n_params: int,
                     ar1: tuple[np.ndarray, float, float] | None = None
                     ) -> tuple[dict[str, float | tuple[float, ...]], ...]:
    """σ² (JᵀJ)⁻¹ with J the derivatives of the model with respect to every fitted parameter
    (nuisance included) at the fit, σ² = RSS / (n − p).

    ``ar1`` = (time order, φ, σ²): the errors are AR(1) in time order of marginal variance σ², and the
    covariance of the least-squares values is the sandwich (JᵀJ)⁻¹ JᵀΣJ (JᵀJ)⁻¹ with Σ_ij = σ² φ^|i−j|.  The
    ordinary σ²(JᵀJ)⁻¹ takes the correlated errors for independent ones: for a slow effect about (1 − φ)/(1 + φ)
    of the variance (a standard error 0.23 of the true one at φ 0.9); for one that changes with every sweep of
    the travel (a function of the position) it can be larger than the true one."""
    blocks, owners = [obs.nuisance], []
    for i, e in enumerate(effects):
        if e.free:
            names, jac = basis.jacobian(e, obs)
            # a table in its gauge (table_gauge): the directions the nuisance absorbs are not its own
            blocks.append(without_nuisance(jac, obs.nuisance) if e.type in basis.TABLES else jac)
            owners += [(i, n) for n in names]
    j = np.column_stack(blocks)
    dof = obs.n - n_params
    out: list[dict[str, float | tuple[float, ...]]] = [{} for _ in effects]
    if dof <= 0 or not owners:
        return tuple(out)
    js, norms = _scaled(j)
    inv = np.linalg.pinv(js.T @ js, rcond=1e-12, hermitian=True)
    if ar1 is None:
        cov = inv * (rss / dof)
    else:
        order, phi, sigma2 = ar1
        jo = js[order]
        cov = inv @ (jo.T @ serial.r_times(jo, phi)) @ inv * sigma2
    se_all = np.sqrt(np.clip(np.diag(cov), 0, None)) / norms
    tables: dict[int, list[float]] = {}
    for (i, name), s in zip(owners, se_all[obs.nuisance.shape[1]:], strict=True):
        if "[" in name:
            tables.setdefault(i, []).append(float(s))
            out[i][name.split("[")[0]] = tuple(tables[i])
        else:
            out[i][name] = float(s)
    return tuple(out)


# -- criteria ---------------------------------------------------------------------------------------------
def bic(rss: float, n: int, k: int) -> float:
    """Schwarz's criterion for Gaussian errors: n ln(RSS/n) + k ln n."""
    return n * math.log(max(rss, 1e-300) / n) + k * math.log(n)


@dataclass(frozen=True)
class FoldFits:
    """A design fitted with each cross-validation fold held out: per fold the held-out sum of squared
    prediction errors (None where holding the fold out loses rank) and the fold's size."""

    sse: tuple[float | None, ...]
    sizes: tuple[int, ...]


def fold_fits(x: np.ndarray, y: np.ndarray, folds: np.ndarray) -> FoldFits:
    """Fit ``x`` to ``y`` once per fold of ``folds`` held out (normal equations: the Gram matrix of
    the rest is the total minus the fold's)."""
    order = np.argsort(folds, kind="stable")
    _, starts, sizes = np.unique(folds[order], return_index=True, return_counts=True)
    xs, _ = _scaled(x[order])
    ys = y[order]
    cuts = [slice(a, a + m) for a, m in zip(starts, sizes, strict=True)]
    grams = [xs[c].T @ xs[c] for c in cuts]
    rhs = [xs[c].T @ ys[c] for c in cuts]
    g_all, b_all = sum(grams), sum(rhs)
    full_rank = len(_eig(g_all)[0])
    sse: list[float | None] = []
    for c, g, b in zip(cuts, grams, rhs, strict=True):
        w, v = _eig(g_all - g)
        if len(w) < full_rank:
            sse.append(None)
            continue
        beta = v @ ((v.T @ (b_all - b)) / w)
        sse.append(max(float(ys[c] @ ys[c] - 2 * beta @ b + beta @ g @ beta), 0.0))
    return FoldFits(tuple(sse), tuple(int(m) for m in sizes))


def cv_rmse(fits: list[FoldFits]) -> list[float | None]:
    """Grouped cross-validation RMSE of each design, over the folds every design can hold out
    (None when there is no such fold)."""
    usable = [k for k in range(len(fits[0].sizes)) if all(f.sse[k] is not None for f in fits)]
    if not usable:
        return [None for _ in fits]
    count = sum(fits[0].sizes[k] for k in usable)
    return [math.sqrt(sum(f.sse[k] for k in usable) / count) for f in fits]  # type: ignore[misc]

