"""Evaluation of a saved run (``guideway process``): the set-up's validation limits, the evaluator of
each run kind, the pass/fail verdict against ``[tolerance]``, and the air-index check."""
