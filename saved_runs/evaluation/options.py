"""The evaluation options the front ends offer: the straightness decoupling methods (``--method``)
and the ISO 230-2 editions (``--edition``), and the defaults of ``guideway process`` (the catalogue says
when a run's values were evaluated with others).

Written out here, so that the command line's choices load no NumPy (``guideway --help``);
tests/saved_runs/test_front_end_choices.py holds them equal to processing.decoupling.METHODS and
processing.iso230_2.EDITIONS.
"""

METHODS = ("exact", "first-order", "patent")
EDITIONS = ("ISO 230-2:1997", "ISO 230-2:2006", "ISO 230-2:2014")

DECISION_RULES = ("simple", "guard-band", "iso14253")  # saved_runs.evaluation.tolerance.DECISION_RULES
DEFAULT_METHOD = "exact"  # processing.decoupling.DEFAULT_METHOD
DEFAULT_EDITION = EDITIONS[-1]  # processing.iso230_2.DEFAULT_EDITION
DEFAULT_K = 2.0  # ISO 230-2 coverage factor (saved_runs.evaluation.positioning)
MC_TRIALS = 10_000
MC_SAMPLE_BUDGET = 2_000_000  # trials x stations: bounds Monte Carlo time and memory on long runs


def default_mc_trials(stations: int) -> int:
    """10 000 Monte Carlo trials, fewer (not below 1000) when trials x stations would pass 2e6."""
    return max(1000, min(MC_TRIALS, MC_SAMPLE_BUDGET // max(stations, 1)))
