"""The X-table / Z-head machine of the simulated-run tests, its volumetric error written from rigid-body
kinematics (independently of processing/volumetric): X in the workpiece chain (frame origin at
(x, 0, 0)), Z in the tool chain (carriage at (0, 0, z)), the tool point at (0, 0, z + tool_z_mm).
A tool-chain error adds δ + ε × (tool − the carriage), a workpiece-chain error subtracts
δ + ε × (tool − the table's origin); a squareness S_XZ tilts Z so that it gains −z·S along X."""

from __future__ import annotations

import numpy as np


def xz_machine(name: str, x_errors: str, z_errors: str, extra: str = "") -> str:
    """The machine file: X table over 0 … 400 mm, Z head over 0 … 300 mm, the tool 80 mm below it;
    ``x_errors`` / ``z_errors`` the lines of their errors tables, ``extra`` more top-level tables."""
    return (f'kind = "machine"\nname = "{name}"\n[tool]\noffset_mm = [0.0, 0.0, -80.0]\n{extra}'
            '[[workpiece_chain]]\nname = "X"\ntype = "prismatic"\ndirection = "+X"\nrange = [0.0, 400.0]\n'
            f'[workpiece_chain.errors]\n{x_errors}'
            '[[tool_chain]]\nname = "Z"\ntype = "prismatic"\ndirection = "+Z"\nrange = [0.0, 300.0]\n'
            f'[tool_chain.errors]\n{z_errors}')


def xz_first_order(x: float, z: float, tool_z_mm: float, d_x: np.ndarray, e_x: np.ndarray, d_z: np.ndarray,
                   e_z: np.ndarray, s_xz_urad: float = 0.0) -> np.ndarray:
    """The position error (µm) of the tool relative to the workpiece to first order: d_* the translation
    errors (µm) and e_* the rotation errors (µrad) of X and Z in machine axes, positions mm."""
    tool = np.array([0.0, 0.0, z + tool_z_mm])
    tool_part = np.asarray(d_z) + np.cross(np.asarray(e_z) * 1e-6, tool - np.array([0.0, 0.0, z])) * 1e3
    workpiece_part = np.asarray(d_x) + np.cross(np.asarray(e_x) * 1e-6, tool - np.array([x, 0.0, 0.0])) * 1e3
    return tool_part - workpiece_part + np.array([-z * s_xz_urad * 1e-3, 0.0, 0.0])
