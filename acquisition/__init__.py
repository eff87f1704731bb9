"""Workflows as plans (generators of messages) run by a small engine.

Plans never touch hardware or UI; the engine executes their messages against
devices, asks an injected operator, and hands records to subscribers (the run
store, live processing, the UI).  Only :mod:`acquisition.simulation` imports
``mocks`` (the composition root of a simulated session).
"""
