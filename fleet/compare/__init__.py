"""Before/after comparison of two saved runs of the same kind (``guideway compare``): both evaluated as
``guideway process`` evaluates them, matched target by target (positioning) or station by station
(straightness), the change with its expanded uncertainty, the values side by side, overlay plots and
the HTML report (docs/compare.md)."""
