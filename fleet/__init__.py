"""The fleet view of saved runs: many run directories across machines and years.

``catalog`` (the catalogue database of runs: SQLite for one rig, PostgreSQL for a shared fleet),
``compare`` (two runs of one kind: the change and its uncertainty) and ``trend`` (a value over the
catalogued runs of an axis).  It reads run directories through ``saved_runs`` and writes nothing
into them (docs/fleet.md, docs/compare.md).
"""
