"""The names and defaults the front ends offer are written out in NumPy-free modules (so that
``guideway --help`` loads no numerical library); each must equal the processing module that
defines it, or a choice on the command line would name something processing does not know."""

from __future__ import annotations

import processing.air_index
import processing.compensation.models
import processing.compensation.tables
import processing.decoupling
import processing.iso230_2
from saved_runs.evaluation import air, options
from saved_runs.export import options as export_options


def test_evaluation_choices_are_those_of_processing() -> None:
    assert options.METHODS == processing.decoupling.METHODS
    assert options.EDITIONS == processing.iso230_2.EDITIONS
    assert processing.iso230_2.DEFAULT_EDITION == options.EDITIONS[-1]  # the TUI starts at the last one


def test_export_choices_are_those_of_processing() -> None:
    assert export_options.MODEL_NAMES == processing.compensation.models.MODEL_NAMES
    assert export_options.DEFAULT_POLYNOMIAL_DEGREE == processing.compensation.models.DEFAULT_POLYNOMIAL_DEGREE
    assert export_options.MODES == processing.compensation.tables.MODES


def test_air_index_choices_are_those_of_processing() -> None:
    assert air.EQUATIONS == processing.air_index.EQUATIONS
    assert air.DEFAULT_EQUATION == processing.air_index.DEFAULT_EQUATION
    assert air.HENE_WAVELENGTH_NM == processing.air_index.HENE_WAVELENGTH_NM
    assert air.DEFAULT_CO2_PPM == processing.air_index.DEFAULT_CO2_PPM
    for eq in air.EQUATIONS:
        assert air.equation_name(eq) == processing.air_index.EQUATION_NAMES[eq]


def test_evaluation_defaults_are_those_of_processing() -> None:
    """The defaults the catalogue compares a run's evaluation options with (saved_runs.evaluation.options)."""
    import inspect

    from saved_runs.evaluation.positioning import evaluate_positioning_run
    from saved_runs.evaluation.straightness import evaluate_straightness_run

    assert options.DEFAULT_METHOD == processing.decoupling.DEFAULT_METHOD
    assert options.DEFAULT_EDITION == processing.iso230_2.DEFAULT_EDITION
    assert inspect.signature(evaluate_positioning_run).parameters["k"].default == options.DEFAULT_K
    assert inspect.signature(evaluate_straightness_run).parameters["method"].default == options.DEFAULT_METHOD
