"""The catalogue database of saved runs (SQLite by default, PostgreSQL for a fleet; docs/fleet.md)."""
