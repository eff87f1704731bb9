"""Recording a run: from set-up file to run directory.

Workflows are plans (generators of messages) run by a small engine.  Plans never touch hardware or
UI; the engine executes their messages against devices (:mod:`.rig`), asks an injected operator,
and hands records to subscribers (the run store of ``saved_runs``, live processing, the UI).  Set-up
files are read in :mod:`.setup`; only :mod:`.simulated` imports ``mocks`` (the simulated rig).
"""
