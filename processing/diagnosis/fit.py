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
from . import basis
from .observations import Observations

RANK_RTOL = 1e-9
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
    norms = np.linalg.norm(x, axis=0)
    norms[norms == 0] = 1.0
    return x / norms, norms


def solve(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, float, int]:
    """Least squares on scaled columns: (coefficients, RSS, rank)."""
    xs, norms = _scaled(x)
    sol, _, rank, s = np.linalg.lstsq(xs, y, rcond=None)
    tol = s[0] * RANK_RTOL if s.size else 0.0
    rank = int(np.sum(s > tol)) if s.size else 0
    coef = sol / norms
    r = y - x @ coef
    return coef, float(r @ r), rank


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
        u, s, _ = np.linalg.svd(_scaled(base)[0], full_matrices=False)
        u = u[:, s > (s[0] * RANK_RTOL if s.size else 0)]
        self.r0 = y - u @ (u.T @ y)
        self.rss0 = float(self.r0 @ self.r0)
        self.pos, inv = np.unique(positions, return_inverse=True)
        self.count = np.bincount(inv, minlength=len(self.pos)).astype(float)
        self.r_agg = np.bincount(inv, weights=self.r0, minlength=len(self.pos))
        self.u_agg = np.zeros((len(self.pos), u.shape[1]))
        np.add.at(self.u_agg, inv, u)

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

    def best(self, grid: np.ndarray, around: float | None = None) -> float:
        """The wavelength of least RSS: over ``grid``, or refined near ``around``."""
        if around is None:
            rss = np.concatenate([self.rss(chunk) for chunk in np.array_split(grid, max(1, len(grid) // 256))])
            f0 = 1.0 / grid[int(np.argmin(rss))]
        else:
            f0 = 1.0 / around
        span = float(self.pos[-1] - self.pos[0]) or 1.0
        df = 1.0 / (OVERSAMPLE * span)
        lo, hi = max(f0 - df, 0.2 / span), f0 + df
        res = optimize.minimize_scalar(lambda f: float(self.rss(np.array([1.0 / f]))[0]), bounds=(lo, hi),
                                       method="bounded", options={"xatol": df * 1e-4})
        trial = np.array([f0, float(res.x)])
        return float(1.0 / trial[int(np.argmin(self.rss(1.0 / trial)))])


def free_wavelength(e: Effect) -> bool:
    return e.type == "periodic" and "wavelength_mm" in e.free


# -- the fit ---------------------------------------------------------------------------------------------
def fit_model(obs: Observations, effects: tuple[Effect, ...] | list[Effect],
              wavelength_hint: dict[int, float] | None = None) -> Fit:
    """Fit the free parameters of ``effects`` (and the nuisance) to ``obs``.

    ``wavelength_hint``: start wavelengths of free-wavelength periodic effects (refined
    locally); one without a hint or a value is searched over :func:`wavelength_grid`.
    """
    effects = tuple(effects)
    target = obs.y_um - fixed_part(effects, obs)
    hints = dict(wavelength_hint or {})
    nonlinear = [i for i, e in enumerate(effects) if free_wavelength(e)]
    wl: dict[int, float] = {}
    for i in nonlinear:
        start = hints.get(i, effects[i].params.get("wavelength_mm"))
        if start is not None:
            wl[i] = float(start)  # type: ignore[arg-type]
    grid, _ = wavelength_grid(obs.values["position_mm"]) if nonlinear else (np.empty(0), 1.0)
    for _sweep in range(2 if len(nonlinear) > 1 else 1):
        for i in nonlinear:
            if i not in wl and len(grid) == 0:
                raise ValueError("a periodic wavelength cannot be searched with fewer than 4 distinct positions")
            unknown = {j for j in nonlinear if j not in wl}
            base, _ = _design(effects, obs, wl, skip=unknown | {i})
            scan = _Scan(base, target, obs.values["position_mm"])
            wl[i] = scan.best(grid, around=wl.get(i))
    x, cols = _design(effects, obs, wl)
    coef, rss, rank = solve(x, target)
    fitted = list(effects)
    pos = obs.nuisance.shape[1]
    for i, c in cols:
        k = c.matrix.shape[1]
        fitted[i] = effects[i].with_params(c.to_params(coef[pos:pos + k]))
        pos += k
    residual = target - x @ coef
    n_params = rank + len(nonlinear)
    se = _standard_errors(obs, tuple(fitted), rss, n_params)
    return Fit(tuple(fitted), residual, rss, n_params, x, target, se)


def _standard_errors(obs: Observations, effects: tuple[Effect, ...], rss: float, n_params: int
                     ) -> tuple[dict[str, float | tuple[float, ...]], ...]:
    """σ² (JᵀJ)⁺ with J the derivatives of the model with respect to every fitted parameter
    (nuisance included) at the fit, σ² = RSS / (n − p)."""
    blocks, owners = [obs.nuisance], []
    for i, e in enumerate(effects):
        if e.free:
            names, jac = basis.jacobian(e, obs)
            blocks.append(jac)
            owners += [(i, n) for n in names]
    j = np.column_stack(blocks)
    dof = obs.n - n_params
    out: list[dict[str, float | tuple[float, ...]]] = [{} for _ in effects]
    if dof <= 0 or not owners:
        return tuple(out)
    js, norms = _scaled(j)
    cov = np.linalg.pinv(js.T @ js, rcond=1e-12, hermitian=True) * (rss / dof)
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


def cv_rmse(designs: list[np.ndarray], y: list[np.ndarray], folds: np.ndarray) -> list[float | None]:
    """Grouped cross-validation RMSE of each design (each fold held out, fitted on the rest).

    Folds where a design loses rank when its fold is held out (an effect that only that fold can
    estimate) are left out for all designs alike; None when no fold is left.
    """
    fold_list = np.unique(folds)
    parts = []
    for x, target in zip(designs, y, strict=True):
        xs, _ = _scaled(x)
        grams = np.stack([xs[folds == f].T @ xs[folds == f] for f in fold_list])
        rhs = np.stack([xs[folds == f].T @ target[folds == f] for f in fold_list])
        yy = np.array([target[folds == f] @ target[folds == f] for f in fold_list])
        parts.append((grams, rhs, yy))
    usable = np.ones(len(fold_list), dtype=bool)
    solutions = []
    for grams, rhs, _ in parts:
        g_all, b_all = grams.sum(axis=0), rhs.sum(axis=0)
        full_rank = _rank(g_all)
        sols = []
        for k in range(len(fold_list)):
            g = g_all - grams[k]
            if _rank(g) < full_rank:
                usable[k] = False
                sols.append(None)
                continue
            sols.append(np.linalg.lstsq(g, b_all - rhs[k], rcond=None)[0])
        solutions.append(sols)
    if not usable.any():
        return [None for _ in designs]
    out: list[float | None] = []
    for (grams, rhs, yy), sols in zip(parts, solutions, strict=True):
        sse, count = 0.0, 0
        for k in np.flatnonzero(usable):
            beta = sols[k]
            sse += float(yy[k] - 2 * beta @ rhs[k] + beta @ grams[k] @ beta)
            count += int(np.sum(folds == fold_list[k]))
        out.append(math.sqrt(max(sse, 0.0) / count))
    return out


def _rank(gram: np.ndarray) -> int:
    ev = np.linalg.eigvalsh(gram)
    return int(np.sum(ev > max(ev[-1], 0.0) * 1e-10)) if ev.size else 0
