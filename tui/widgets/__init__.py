"""Widgets of the TUI: a braille plot, live readouts."""
