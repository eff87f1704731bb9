"""Catalogue of saved runs: the runs in a folder, from their run.json alone (the TUI's run browser)."""
