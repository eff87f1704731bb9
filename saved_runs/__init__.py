"""Everything done to a run directory once it is recorded (docs/run-format.md is the contract).

Sub-packages, one per job, each importing only those above it in this list:

* :mod:`.store` — read and write run directories (atomic files, the run format);
* :mod:`.catalog` — the saved runs in a folder;
* :mod:`.importing` — runs from data measured with another tool;
* :mod:`.results` — the results files (CSV, PNG) of an evaluation;
* :mod:`.evaluation` — validation limits, tolerance verdicts, straightness and ISO 230-2 evaluation;
* :mod:`.export` — CNC compensation tables and their residuals;
* :mod:`.report` — the printable HTML report of a run;
* :mod:`.certificate` — the calibration certificate (PDF) of a run;
* :mod:`.diagnosis` — which physical effect a run's model lacks;
* :mod:`.volumetric` — the volumetric machine model from a machine file and its runs.

:mod:`.errors` (the one-line errors of every layer) and :mod:`.toml_file` (reading TOML tables with
one-line errors) serve them all.  Nothing here opens a device: recording is ``acquisition``'s job.
"""
