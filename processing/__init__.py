"""Pure evaluation functions on arrays and DataFrames (no I/O, no devices).

Column schemas and units are documented in :mod:`processing.columns`; sign
and axis conventions in docs/conventions.md.
"""
