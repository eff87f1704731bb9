"""As-found run → exported table → as-left run measured with the table active: which table it was, and per
ISO 230-2 value what the table removed against what the export predicted (``guideway verify``,
docs/compensation.md "Verify"); built on fleet.compare (matching, change and U, overlay)."""
