"""Tests of the saved-runs package (everything done to a run directory)."""
