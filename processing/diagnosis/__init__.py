"""Diagnosis of a run against a model of physical effects (docs/diagnosis.md): the
observations a run offers, the effects' contributions to them, the least-squares fits and
the selection rule.  Pure functions on arrays; reading runs and model files is in
``saved_runs/diagnosis/diagnose.py``."""
