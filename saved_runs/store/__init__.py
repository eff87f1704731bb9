"""Run directories on disk (docs/run-format.md): the format's names and columns, atomic files, the
crash-safe writer and the validating reader."""
