"""The evaluation options the front ends offer: the straightness decoupling methods (``--method``)
and the ISO 230-2 editions (``--edition``).

Written out here, so that the command line's choices load no NumPy (``guideway --help``);
tests/saved_runs/test_front_end_choices.py holds them equal to processing.decoupling.METHODS and
processing.iso230_2.EDITIONS.
"""

METHODS = ("exact", "first-order", "patent")
EDITIONS = ("ISO 230-2:1997", "ISO 230-2:2006", "ISO 230-2:2014")
