"""The optional ``[tolerance]`` of a set-up and the pass/fail verdict of a run against it.

Straightness (docs/setup-straightness.toml)::

    [tolerance]
    straightness_um = 10.0            # the straightness of the measured length ...
    reference_line = "minimum_zone"   # ... against this line (minimum_zone, least_squares, endpoint)

Positioning (docs/setup-positioning.toml): ISO 230-2 values of the axis, ``<quantity>_um``
(rotary axes ``<quantity>_arcsec``) for A, A_up, A_down, E, E_up, E_down, M, R, R_up, R_down, B::

    [tolerance]
    A_um = 15.0
    R_um = 6.0

A check passes when the value is at most its tolerance.  When the expanded uncertainty U of
the value is known (straightness with Monte Carlo), a value within U of the limit is flagged:
conformance (or non-conformance) is then not proven in the sense of ISO 14253-1.  A value that
could not be evaluated makes the verdict "not evaluated" unless another check fails.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

from ..errors import RunFormatError, SetupError

REFERENCE_LINES = ("minimum_zone", "least_squares", "endpoint")
POSITIONING_QUANTITIES = ("A", "A_up", "A_down", "E", "E_up", "E_down", "M", "R", "R_up", "R_down", "B")


def _positive(where: str, key: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not (math.isfinite(value) and value > 0):
        raise SetupError(f"{where}: [tolerance] {key} must be a positive number, got {value!r}")
    return float(value)


def straightness_tolerance(data: Any, where: str = "setup") -> dict[str, Any]:
    """Validated ``[tolerance]`` of a straightness set-up ({} when absent)."""
    if not data:
        return {}
    if not isinstance(data, dict):
        raise SetupError(f"{where}: [tolerance] must be a table")
    extra = sorted(set(data) - {"straightness_um", "reference_line"})
    if extra:
        raise SetupError(f"{where}: unknown key {extra[0]!r} in [tolerance]; use straightness_um and reference_line")
    if "straightness_um" not in data:
        raise SetupError(f"{where}: [tolerance] straightness_um is missing")
    line = data.get("reference_line", "minimum_zone")
    if line not in REFERENCE_LINES:
        raise SetupError(f"{where}: [tolerance] reference_line must be one of {', '.join(REFERENCE_LINES)}, "
                         f"got {line!r}")
    return {"straightness_um": _positive(where, "straightness_um", data["straightness_um"]), "reference_line": line}


def positioning_tolerance(data: Any, unit: str, where: str = "setup") -> dict[str, float]:
    """Validated ``[tolerance]`` of a positioning set-up ({} when absent); ``unit`` um or arcsec."""
    if not data:
        return {}
    if not isinstance(data, dict):
        raise SetupError(f"{where}: [tolerance] must be a table")
    allowed = {f"{q}_{unit}" for q in POSITIONING_QUANTITIES}
    extra = sorted(set(data) - allowed)
    if extra:
        raise SetupError(f"{where}: unknown key {extra[0]!r} in [tolerance]; use ISO 230-2 values "
                         f"{', '.join(f'{q}_{unit}' for q in POSITIONING_QUANTITIES)}")
    return {k: _positive(where, k, v) for k, v in data.items()}


@dataclass(frozen=True)
class Check:
    """One tolerance check: ``quantity`` (its name in the results), ``value`` and ``tolerance``
    in ``unit``, ``result`` pass / fail / not evaluated, ``uncertainty`` U (k = 2) when known and
    whether the value lies within U of the limit."""

    quantity: str
    value: float | None
    tolerance: float
    unit: str
    result: str
    uncertainty: float | None = None
    within_uncertainty: bool = False

    def text(self) -> str:
        value = "not evaluated" if self.value is None else f"{self.value:.3f} {self.unit}"
        note = " (within U of the limit: not proven, ISO 14253-1)" if self.within_uncertainty else ""
        return f"{self.quantity} {value} <= {self.tolerance:g} {self.unit}: {self.result.upper()}{note}"


def check(quantity: str, value: float, tolerance: float, unit: str, uncertainty: float | None = None) -> Check:
    if not math.isfinite(value):
        return Check(quantity, None, tolerance, unit, "not evaluated")
    u = uncertainty if uncertainty is not None and math.isfinite(uncertainty) else None
    within = u is not None and abs(value - tolerance) <= u
    return Check(quantity, value, tolerance, unit, "pass" if value <= tolerance else "fail", u, within)


@dataclass(frozen=True)
class Verdict:
    """The checks against ``[tolerance]``; ``incomplete`` says which planned steps the run lacks (a run
    with a gap cannot pass: the missing station could be the one out of tolerance); ``missing`` says in
    plain words why a value could not be evaluated (``1 run per direction, A and R need 2+``)."""

    checks: tuple[Check, ...]
    incomplete: str = ""
    missing: str = ""

    @property
    def result(self) -> str:
        results = {c.result for c in self.checks}
        if "fail" in results:
            return "fail"
        return "not evaluated" if "not evaluated" in results or self.incomplete else "pass"

    @property
    def reason(self) -> str:
        """Why the verdict is NOT EVALUATED, in plain words ('' for any other verdict)."""
        if self.result != "not evaluated":
            return ""
        why = []
        if any(c.result == "not evaluated" for c in self.checks):
            names = ", ".join(c.quantity for c in self.checks if c.result == "not evaluated")
            why.append(self.missing or f"{names} could not be computed from the points")
        if self.incomplete:
            why.append(f"run incomplete: {self.incomplete}")
        return "; ".join(why)

    def to_dict(self) -> dict[str, Any]:
        return {"result": self.result, "checks": [asdict(c) for c in self.checks],
                **({"incomplete": self.incomplete} if self.incomplete else {}),
                **({"reason": self.reason} if self.reason else {})}

    def text(self) -> str:
        why = f": {self.reason}" if self.reason else ""
        return f"verdict: {self.result.upper()}{why} ({'; '.join(c.text() for c in self.checks)})"


def verdict_dict(verdict: Verdict | None) -> dict[str, Any]:
    """``{"verdict": ...}`` for ``process --json`` (None without a ``[tolerance]``)."""
    return {"verdict": None if verdict is None else verdict.to_dict()}


def _stored(meta: dict[str, Any], where: str, parse: Any, *args: Any) -> Any:
    try:
        return parse((meta.get("setup") or {}).get("tolerance"), *args, where)
    except SetupError as exc:
        raise RunFormatError(str(exc)) from None


def straightness_verdict(meta: dict[str, Any], where: str, straightness_um: dict[str, float],
                         uncertainty_um: dict[str, float], incomplete: str = "") -> Verdict | None:
    """The verdict of a straightness run against run.json ``setup.tolerance`` (None without one);
    ``straightness_um`` and ``uncertainty_um`` (U, k = 2) per reference line; ``incomplete``: the gap
    in the run, if any (then the verdict is not PASS)."""
    tol = _stored(meta, where, straightness_tolerance)
    if not tol:
        return None
    line = tol["reference_line"]
    return Verdict((check(f"straightness ({line.replace('_', ' ')} line)", straightness_um.get(line, math.nan),
                          tol["straightness_um"], "um", uncertainty_um.get(line)),), incomplete)


def positioning_verdict(meta: dict[str, Any], where: str, axis: dict[str, float], unit: str,
                        approaches: tuple[list[int], list[int]] | None = None) -> Verdict | None:
    """The verdict of a positioning run against run.json ``setup.tolerance`` (None without one);
    ``approaches``: the approaches at each target up and down, to say in plain words why a value
    could not be evaluated (A and R need a standard deviation, so 2 or more approaches, ISO 230-2)."""
    tol = _stored(meta, where, positioning_tolerance, unit)
    if not tol:
        return None
    checks = []
    for key, value in tol.items():
        q = key[: -len(unit) - 1]  # A_um -> A
        checks.append(check(q, axis.get(q, math.nan), value, unit))
    missing = ""
    if approaches is not None and any(c.value is None for c in checks):
        up, down = approaches
        measured = [n for n in (up, down) if n and max(n) > 0]
        if len(measured) < 2:
            missing = "one direction only (unidirectional test): A, E, M and B need both directions"
        elif any(max(n) < 2 for n in measured):
            runs = min(max(n) for n in measured)
            missing = f"{runs} run per direction, A and R need 2+"
        elif any(min(n) < 2 for n in measured):
            missing = "some targets have fewer than 2 approaches per direction (missing points), A and R need 2+"
    return Verdict(tuple(checks), missing=missing)
