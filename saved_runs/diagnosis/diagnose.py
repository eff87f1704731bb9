"""``guideway diagnose``: where a run and its model disagree, which missing effect explains it,
and the gap shrinking as the effects are added (docs/diagnosis.md).

Reads the run and the model file, builds the run's observations (processing/diagnosis/
observations.py: positioning deviations after environmental compensation; straightness heights
by the exact decoupling and the interferometer's X channel), runs the selection loop on every
channel (processing/diagnosis/select.py) and presents the result: one JSON object, a terminal
summary, an HTML report with a plot per step, and the final model as a reusable model file.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from processing.air_index import air_index
from processing.decoupling import decouple, sensor_height_um
from processing.diagnosis import serial
from processing.diagnosis.fit import orthonormal_basis
from processing.diagnosis.observations import Observations, positioning_observations, straightness_observations
from processing.diagnosis.select import ChannelDiagnosis, Rule, default_rule, diagnose_channel
from processing.effects import Effect
from processing.environment import EnvironmentSettings
from processing.passes import check_order

from ..errors import RunFormatError, UserError
from ..evaluation.limits import out_of_range
from ..evaluation.positioning import positioning_deviations
from ..evaluation.straightness import check_finite, run_geometry
from ..store.files import write_text_atomic
from ..store.format import run_axis
from ..store.reader import LoadedRun, load_run
from .model_file import EffectModel, commented_effect, empty_model, load_model, model_toml
from .remains import not_named_because, remains


@dataclass(frozen=True)
class Diagnosis:
    """The diagnosis of one run: a :class:`ChannelDiagnosis` per channel, the primary one first."""

    run: LoadedRun
    model: EffectModel
    channels: tuple[ChannelDiagnosis, ...]
    notes: tuple[str, ...] = ()

    @property
    def primary(self) -> ChannelDiagnosis:
        return self.channels[0]

    @property
    def named(self) -> list[str]:
        return [name for ch in self.channels for name in ch.named]

    @property
    def ambiguous(self) -> list[list[str]]:
        return [list(g) for ch in self.channels for g in ch.ambiguous]

    def final_effects(self) -> list[tuple[Effect, dict[str, Any], str]]:
        """Every effect of the final model with its standard errors and the channel it acts on."""
        out = []
        for ch in self.channels:
            for effect, se in zip(ch.final.effects, ch.final.se, strict=True):
                out.append((effect, se, ch.obs.channel))
        return out

    def to_dict(self) -> dict[str, Any]:
        """The object ``guideway diagnose --json`` prints (docs/diagnosis.md)."""
        p = self.primary
        steps = []
        for ch in self.channels:
            for s in ch.steps:
                steps.append({"effect": s.test.effect.type, "label": s.test.effect.label, "channel": ch.obs.channel,
                              "params": _params(s.effect), "se": _clean(s.fit.se[-1]),
                              "se_ar1_phi": s.fit.se_ar1_phi, "rms_um": s.fit.rms_um,
                              "max_um": s.fit.max_um, "noise_um": s.noise.sigma_um, "evidence": s.test.evidence(),
                              "evidence_in_final": s.in_final.evidence() if s.in_final else None,
                              "ambiguous_with": list(s.ambiguous_with),
                              "alternatives": [_params(a) | {"type": a.type} for a in s.alternatives],
                              "implausible": s.implausible or None, "not_named_because": not_named_because(ch, s)})
        out = {
            "kind": self.run.kind,
            "run": str(self.run.path),
            "model": self.model.source,
            "channel": p.obs.channel,
            "baseline": _summary(p.baseline),
            "steps": steps,
            "final": {**_summary(p.final), "se_ar1_phi": p.final.se_ar1_phi,
                      # the effect as a model file states it (an Abbe effect's own channel: pitch or yaw), and
                      # the observed channel it acts on in its own key
                      "model": [{**effect.to_dict(), "se": _clean(se), "diagnosis_channel": ch}
                                for effect, se, ch in self.final_effects()]},
            "named": self.named,
            "ambiguous": self.ambiguous,
            "noise_um": p.noise.sigma_um,
            "noise": {"source": p.noise.source, "dof": p.noise.dof, "baseline_um": p.baseline_noise.sigma_um},
            "disagreement": p.disagreement,
            "not_testable": {k: v for ch in self.channels for k, v in ch.not_testable.items()},
            "residual_structure": p.structure,
            "remains": remains(p),
            "candidates": [{"effect": t.effect.type, "label": t.effect.label, **t.evidence()} for t in p.last_round],
            "rule": p.rule.to_dict(),
            "notes": list(self.notes),
            "channels": {ch.obs.channel: {"points": ch.obs.n, "baseline": _summary(ch.baseline),
                                          "final": _summary(ch.final), "noise_um": ch.noise.sigma_um,
                                          "noise_source": ch.noise.source, "named": ch.named,
                                          "cv_folds": ch.obs.fold_basis, "stands_out": _stands_out(ch),
                                          "disagreement": ch.disagreement, "residual_structure": ch.structure,
                                          "remains": remains(ch)} for ch in self.channels},
        }
        return _clean(out)

    def print_summary(self, stream: TextIO) -> None:
        for ch in self.channels:
            o = ch.obs
            noise = ch.baseline_noise
            print(f"{o.channel} channel ({o.n} points): baseline RMS {ch.baseline.rms_um:.3f} um, max "
                  f"{ch.baseline.max_um:.3f} um; noise {noise.sigma_um:.3f} um ({noise.source})", file=stream)
            if ch.rule.ar1_history:
                past = ch.rule.ar1_history
                print(f"  serial correlation: estimated from this run and {len(past)} earlier run(s) "
                      f"({sum(e.n for e in past)} points, AR(1) coefficients "
                      f"{', '.join(f'{e.phi:.2f}' for e in past)})", file=stream)
            for region, info in ch.disagreement.items():
                if isinstance(info, dict) and info.get("stand_out"):
                    worst = ", ".join(f"{g['group']} {g['mean_um']:+.3f} um (z {g['z']:+.1f})"
                                      for g in info["stand_out"][:4])
                    print(f"  stands out by {region}: {worst}" + (" ..." if len(info["stand_out"]) > 4 else ""),
                          file=stream)
            for i, s in enumerate(ch.steps, start=1):
                why = not_named_because(ch, s)
                tag = f"{why} (not named)" if why else "named"
                together = ""
                if not s.test.significant and s.in_final is not None:
                    together = (f"; significant only with the later steps: in the final model dBIC "
                                f"{s.in_final.delta_bic:.1f}, p {s.in_final.p_value:.2g}")
                print(f"  step {i}: {s.test.effect.label} {tag}: {format_params(s.effect, s.fit.se[-1])}"
                      f"{se_basis(s.fit.se_ar1_phi)}; "
                      f"RMS {s.fit.rms_um:.3f} um, max {s.fit.max_um:.3f} um "
                      f"(dBIC {s.test.delta_bic:.1f}, p {s.test.p_value:.2g}{together})", file=stream)
            left = remains(ch)
            if not ch.steps and not left:
                print("  nothing significant is missing from the model", file=stream)
            elif not ch.steps:
                print("  no effect of the library is significant, but the residual is not white:", file=stream)
            for sentence in left:
                print(f"  remains: {sentence}", file=stream)
            print(f"  final: RMS {ch.final.rms_um:.3f} um, max {ch.final.max_um:.3f} um, "
                  f"noise {ch.noise.sigma_um:.3f} um", file=stream)
        for note in self.notes:
            print(f"note: {note}", file=stream)
        named = ", ".join(self.named) or "none"
        print(f"named: {named}", file=stream)
        for group in self.ambiguous:
            print(f"ambiguous (cannot be told apart on this run): {' / '.join(group)}", file=stream)

    def model_file_text(self) -> str:
        """The final model as a model file (fitted values; the effects stay free so a later run refits them)."""
        entries: list[tuple[Effect | None, str]] = []
        steps = {id(ch.final.effects[len(ch.model) + i]): (s, ch) for ch in self.channels
                 for i, s in enumerate(ch.steps)}
        for effect, se, channel in self.final_effects():
            step, ch = steps.get(id(effect), (None, None))
            comment = (f"{'added by the diagnosis' if step else 'from the model'} ({channel} channel): "
                       f"{format_params(effect, se) if effect.free else 'fixed'}")
            if step is not None and ch is not None and not ch.is_named(step):
                comment += f"\nnot named: {not_named_because(ch, step)}"
            if step is not None and (step.ambiguous_with or step.implausible):
                # not a finding: written as comments, the choice left to the user
                why = []
                if step.ambiguous_with:
                    why.append(f"the run cannot tell it apart from {', '.join(step.ambiguous_with)}: neither is "
                               "written; uncomment the one you know to be there (a designed experiment separates them)")
                if step.implausible:
                    why.append(f"implausible: {step.implausible}")
                text = [comment, *why, *commented_effect(effect)]
                for alt in step.alternatives:
                    text += [f"or, in its place ({channel} channel):", *commented_effect(alt)]
                entries.append((None, "\n".join(text)))
                continue
            entries.append((effect, comment))
        header = [f"model of run {self.run.path} by guideway diagnose (docs/diagnosis.md)",
                  f"start model: {self.model.source}",
                  f"final RMS {self.primary.final.rms_um:.4f} um, noise {self.primary.noise.sigma_um:.4f} um"]
        return model_toml(self.run.kind, entries, header)


def _stands_out(ch: ChannelDiagnosis) -> list[str]:
    """The groupings (position, run, direction, time) in which some group of the channel's residual under
    the model stands out beyond the noise."""
    return [k for k, v in ch.disagreement.items() if isinstance(v, dict) and v.get("stand_out")]


def _summary(fit: Any) -> dict[str, float]:
    return {"rms_um": fit.rms_um, "max_um": fit.max_um}


def _params(e: Effect) -> dict[str, Any]:
    return {k: (list(v) if isinstance(v, tuple) else v) for k, v in e.params.items() if v is not None}


def _clean(obj: Any) -> Any:
    """JSON-safe: tuples to lists, numpy scalars to floats, NaN/inf to None."""
    if isinstance(obj, dict):
        return {str(k): _clean(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_clean(v) for v in obj]
    if isinstance(obj, bool | np.bool_):
        return bool(obj)
    if isinstance(obj, int | np.integer):
        return int(obj)
    if isinstance(obj, float | np.floating):
        return float(obj) if math.isfinite(obj) else None
    return obj


def se_basis(phi: float) -> str:
    """What the ± of a fit stand for when its errors are correlated in time (empty for independent errors)."""
    return f" (± for errors correlated in time, AR(1) coefficient {phi:.2f})" if phi > 0 else ""


def format_params(e: Effect, se: dict[str, Any]) -> str:
    """``name = value ± se`` of an effect's parameters (tables: their size only)."""
    parts = []
    for name, v in e.params.items():
        if v is None:
            continue
        if isinstance(v, tuple):
            parts.append(f"{name} [{len(v)} values]")
        elif isinstance(v, str):
            parts.append(f"{name} = {v}")
        else:
            s = se.get(name)
            parts.append(f"{name} = {v:.4g}" + (f" ± {s:.2g}" if isinstance(s, float) and math.isfinite(s) else ""))
    return ", ".join(parts)


# -- the run's observations -------------------------------------------------------------------------------------
def run_observations(run: LoadedRun, model: EffectModel) -> list[Observations]:
    """The observed channels of ``run``, primary first."""
    if run.kind == "positioning":
        return [_positioning(run)]
    return list(_straightness(run, any(e.type == "profile_table" for e in model.effects)))


def _positioning(run: LoadedRun) -> Observations:
    if run.meta.get("axis_type", "linear") != "linear":
        raise UserError(f"{run.path}: a rotary axis; the diagnosis covers linear positioning and straightness runs")
    deviations, _, _ = positioning_deviations(run)
    pts = run.points
    try:
        settings = EnvironmentSettings.from_dict((run.meta.get("setup") or {}).get("environment"))
    except ValueError as exc:
        raise RunFormatError(f"{run.path}/run.json: {exc}") from None
    air = [pts[c].to_numpy(dtype=float) for c in ("air_temp_c", "air_pressure_hpa", "humidity_pct")]
    index = None
    if all(np.all(np.isfinite(a)) for a in air):
        index = air_index(air[0], air[1] * 100.0, air[2], co2_ppm=settings.co2_ppm,
                          wavelength_nm=settings.wavelength_nm, equation=settings.index_equation)
    return positioning_observations(pts, deviations["deviation"].to_numpy(dtype=float), index)


def _straightness(run: LoadedRun, reference: bool) -> tuple[Observations, Observations]:
    geometry = run_geometry(run)
    if len(run.points) < 3:
        raise RunFormatError(f"{run.path}: {len(run.points)} point(s) recorded; too few to diagnose")
    check_finite(run, "exact")
    try:
        check_order(run.points)
    except ValueError as exc:
        raise RunFormatError(f"{run.path}: {exc}") from None
    per_point = decouple(run.points, geometry, "exact")
    sensor = sensor_height_um(run.points["sensor_mm"].to_numpy(dtype=float), geometry.sensor_sign)
    return straightness_observations(run.points, per_point, sensor, reference=reference,
                                     lever_x_mm=geometry.sensor_mm[0] - geometry.mirror_mm[0])


def diagnose_run(run_dir: Path | str, model: EffectModel | Path | str | None = None,
                 rule: Rule | None = None, *, accept_out_of_range: bool = False,
                 noise_from: tuple[Path | str, ...] | list[Path | str] = (),
                 progress: Callable[[int, int], None] | None = None) -> Diagnosis:
    """Diagnose the run in ``run_dir`` against ``model`` (a model file, a loaded model, or None: nothing known).

    Values outside the set-up's validation limits are refused as ``process`` refuses them
    (saved_runs.evaluation.limits) unless ``accept_out_of_range``; accepted ones are listed in the notes.
    ``noise_from``: earlier runs of the same machine and axis whose errors' AR(1) coefficient is pooled
    with this run's (:func:`noise_history`).  ``progress(done, total)``: the steps done, each earlier run
    diagnosed and each channel of this run (a front end's progress display)."""
    run = load_run(run_dir)
    accepted = out_of_range(run, accept=accept_out_of_range) if len(run.points) else ()
    if model is None:
        model = empty_model(run.kind)
    elif not isinstance(model, EffectModel):
        model = load_model(model)
    if model.kind != run.kind:
        raise UserError(f"{model.source} is a {model.kind} model; {run.path} is a {run.kind} run")
    channels, notes = [], [f"accepted outside the set-up's limits: {a.text()}" for a in accepted]
    observed = run_observations(run, model)  # before the history: the number of steps is known from the start
    usable = [obs for obs in observed if obs.n >= 3]
    steps = len(noise_from) + len(usable)

    def step(done: int, _total: int = 0) -> None:
        if progress is not None:
            progress(done, steps)

    step(0)
    history, history_notes = noise_history(run, model, noise_from, accept_out_of_range=accept_out_of_range,
                                           progress=step)
    notes += history_notes
    rule = replace(rule or default_rule(run.kind), channels=len(usable))  # alpha is shared by the channels
    for obs in observed:
        notes += obs.notes
        effects = [e for e in model.effects if e.spec.channel == obs.channel]
        if obs.n < 3:
            continue
        try:
            channels.append(diagnose_channel(obs, effects, replace(rule, ar1_history=history.get(obs.channel, ()))))
        except ValueError as exc:
            raise UserError(f"{run.path}: {obs.channel} channel: {exc}") from None
        step(len(noise_from) + len(channels))
    if not channels:
        raise RunFormatError(f"{run.path}: no channel holds enough points to diagnose")
    notes += [note for ch in channels if (note := correlation_note(ch))]
    return Diagnosis(run, model, tuple(channels), tuple(notes))


STRONG_CORRELATION = 0.8
"""From this AR(1) coefficient on, one run's estimate of it leaves the tests of slow effects measurably less
reliable (docs/diagnosis.md: 0.7 % false alarms at φ 0.7, 2 % at 0.9 on the benchmark cycle)."""


def correlation_note(ch: ChannelDiagnosis) -> str:
    """Said whenever the channel's tests were whitened for an estimated AR(1) coefficient: how strong it is, where
    it comes from (the run alone, or pooled with the machine's earlier runs), what the tests and the ± rest on,
    what that does to the tests of slow effects (the measured figures of docs/diagnosis.md) and, from the run
    alone, the remedy.  Empty when no test in the final model used a correlation (φ̂ below detection).

    The tests in the final model (every candidate of the last round, every added effect tested in its place) are
    the ones whose φ̂ is the noise's: an early step's φ̂ also holds the effects still missing from its model."""
    final_tests = [*ch.last_round, *(s.in_final for s in ch.steps if s.in_final is not None)]
    used = [t.ar1_phi for t in final_tests if t.ar1_phi > 0]
    if not used:
        return ""
    phi = ch.final.se_ar1_phi or max(used)
    past = ch.rule.ar1_history
    source = (f"pooled from this run and {len(past)} earlier run(s) of the machine" if past else "from this run alone")
    tested = f"{min(used):.2f}" if max(used) - min(used) < 0.005 else f"{min(used):.2f} … {max(used):.2f}"
    head = (f"{ch.obs.channel} channel: the errors are {'strongly ' if phi >= STRONG_CORRELATION else ''}correlated "
            f"in time (AR(1) coefficient {phi:.2f}, {source}); its tests were whitened for the coefficient estimated "
            f"in each ({tested}) and the ± are the standard errors under it")
    if past:
        return (head + "; with four earlier runs the documented cycle keeps the tests of slow effects (drift, "
                "growth, dead path) under 1 false alarm in 100 and finds a drift of 5 standard errors in over 9 of 10 "
                "up to a coefficient of 0.9 (docs/diagnosis.md)")
    remedy = ("; the machine's earlier runs (--noise-from RUN... or --noise-history N) bring this under 1 in 100 and "
              "over 9 in 10 (docs/diagnosis.md)")
    if phi >= STRONG_CORRELATION:
        return (head + ": one run fixes it too loosely for the tests of slow effects (drift, growth, dead path), "
                "which on the documented cycle name one in about 2 of 100 runs where none is and find a drift of 5 "
                "standard errors in about 8 of 10" + remedy)
    return (head + ": estimated from one run, it leaves the tests of slow effects (drift, growth, dead path) under 1 "
            "false alarm in 100 on the documented cycle up to a coefficient of 0.7, but finds a drift of 5 standard "
            "errors in about 86 of 100 (89 with independent errors)" + remedy)


def noise_history(run: LoadedRun, model: EffectModel, earlier: tuple[Path | str, ...] | list[Path | str],
                  *, accept_out_of_range: bool = False, progress: Callable[[int, int], None] | None = None,
                  ) -> tuple[dict[str, tuple[serial.Ar1Estimate, ...]], list[str]]:
    """The AR(1) coefficient of every channel's errors in each ``earlier`` run: each is diagnosed against
    ``model`` on its own, and φ is estimated from the residual of its final model (an effect it holds is then
    in that model, not taken for correlation).  Returns the estimates per channel and notes (another machine or
    axis, no time recorded).  A run of another kind, or the run itself, is refused.  ``progress(done, total)``:
    after each earlier run."""
    history: dict[str, list[serial.Ar1Estimate]] = {}
    notes: list[str] = []
    seen = {run.path.resolve()}
    for done, path in enumerate(earlier):
        other = load_run(path)
        where = other.path.resolve()
        if where in seen:
            what = "the run being diagnosed" if where == run.path.resolve() else "named twice"
            raise UserError(f"--noise-from {path}: {what}; give other, earlier runs of the same machine and axis")
        seen.add(where)
        if other.kind != run.kind:
            raise UserError(f"--noise-from {path}: a {other.kind} run; {run.path} is a {run.kind} run "
                            "(give earlier runs of the same kind, machine and axis)")
        for key, mine, theirs in (("machine", str(run.meta.get("machine") or ""), str(other.meta.get("machine") or "")),
                                  ("axis", run_axis(run.meta), run_axis(other.meta))):
            if mine and theirs and mine != theirs:
                notes.append(f"noise history: {other.path} is of {key} {theirs!r}, this run of {mine!r}")
        past = diagnose_run(other.path, model, accept_out_of_range=accept_out_of_range)
        for ch in past.channels:
            if ch.obs.n < 8:
                continue
            order = serial.time_order(ch.obs.values, ch.obs.n)
            interval = serial.point_interval_s(ch.obs.values.get("time_min"))
            if interval is None:
                notes.append(f"noise history: {other.path} records no time; its points are taken as evenly spaced "
                             "as this run's")
            phi = serial.matched_phi(ch.final.residual[order], orthonormal_basis(ch.final.design)[order])
            if not math.isnan(phi):
                history.setdefault(ch.obs.channel, []).append(
                    serial.Ar1Estimate(phi, ch.obs.n, interval, str(other.path)))
        if progress is not None:
            progress(done + 1, len(earlier))
    return {k: tuple(v) for k, v in history.items()}, notes


def write_model(diagnosis: Diagnosis, path: Path | str) -> Path:
    path = Path(path)
    try:
        write_text_atomic(path, diagnosis.model_file_text())
    except OSError as exc:
        raise UserError(f"cannot write the model to {path}: {exc.strerror or exc}") from None
    return path
