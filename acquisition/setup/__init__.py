"""Set-up files (docs/setup-*.toml): validated straightness and positioning set-ups, the ISO 230-2
targets and test cycles, the tables both kinds share, and the set-up a run was started with."""
