"""The files of an evaluation next to its run: ``RUN_DIR/results/`` tables, plots and summary.json."""
