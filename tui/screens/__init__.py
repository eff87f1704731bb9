"""The TUI's screens: set-up, connect and warm-up, capture, results, runs; modal dialogs."""
