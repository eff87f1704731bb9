"""User-facing front ends: the ``guideway`` command line and the Textual TUI.

Only this package imports Textual, and only where the TUI itself is started;
the command line does not need it.
"""
