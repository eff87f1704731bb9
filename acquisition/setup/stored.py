"""The set-up a run was started with, rebuilt from its run.json: what a resumed run continues with,
in ``guideway acquire --resume`` and in the TUI alike."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

from processing.geometry import BlockGeometry
from saved_runs.errors import SetupError
from saved_runs.evaluation.limits import ValidationSetup

from .positioning import PositioningSetup, positioning_setup_from_dict
from .shared_tables import DeviceSetup
from .straightness import HandsFreeSetup, StraightnessSetup, WarmupSetup


def straightness_setup_from_run(meta: dict[str, Any]) -> StraightnessSetup:
    """The setup a straightness run was started with, from its run.json (for ``--resume``)."""
    s = meta.get("setup") or {}
    try:
        dev = s.get("devices", {})
        val = dict(s.get("validation", {}))
        if "sensor_range_mm" in val:
            val["sensor_range_mm"] = tuple(val["sensor_range_mm"])
        return StraightnessSetup(
            block_length_mm=float(s["block_length_mm"]),
            stations=int(s["stations"]),
            geometry=BlockGeometry.from_dict(s["geometry"]),
            devices=DeviceSetup(**dev),
            samples_per_reading=int(s.get("samples_per_reading", 5)),
            return_pass=bool(s.get("return_pass", False)),
            warmup=WarmupSetup(**s.get("warmup", {"enabled": False})),
            validation=ValidationSetup(**val),
            uncertainty=dict(s.get("uncertainty", {})),
            tolerance=dict(s.get("tolerance", {})),
            instruments=[dict(i) for i in s.get("instruments", [])],
            auto=HandsFreeSetup(**s.get("auto", {})),
            machine=meta.get("machine", ""), axis=meta.get("axis", ""),
            operator=meta.get("operator", ""), notes=meta.get("notes", ""),
        )
    except (KeyError, TypeError, ValueError) as exc:
        raise SetupError(f"run.json: the stored setup cannot be read back ({exc}); start a new run") from None


def positioning_setup_from_run(meta: dict[str, Any], run_dir: Path | str) -> PositioningSetup:
    """The set-up a positioning run was started with: its run.json ``setup_source`` (the set-up
    file's TOML structure, kept so that the same targets are rebuilt) validated again."""
    if "setup_source" not in meta:
        raise SetupError(f"{run_dir}: run.json holds no setup_source; resume with --setup")
    return positioning_setup_from_dict(meta["setup_source"], f"{run_dir}/run.json setup_source", stored=True)


def resumed_setup(meta: dict[str, Any], run_dir: Path | str,
                  given: StraightnessSetup | PositioningSetup | None = None) -> StraightnessSetup | PositioningSetup:
    """The set-up the interrupted run in ``run_dir`` (run.json ``meta``) continues with.

    Rebuilt from run.json, unless a set-up is ``given`` (``--setup``): a positioning run then takes
    it as it is; a straightness run only when it is the set-up the run started with, apart from
    the device endpoints (a different port after a reboot), which it takes from ``given``.
    ``guideway acquire --resume`` and the TUI's runs browser both resume through here.
    """
    if meta.get("kind") == "positioning":
        return given if given is not None else positioning_setup_from_run(meta, run_dir)
    stored = straightness_setup_from_run(meta)
    if given is None:
        return stored
    if given.to_run_setup() | {"devices": {}} != stored.to_run_setup() | {"devices": {}}:
        raise SetupError(f"{run_dir}: --setup differs from the set-up the run was started with; "
                         "resume without --setup (device endpoints may differ)")
    return replace(stored, devices=given.devices)
