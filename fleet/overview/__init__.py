"""The fleet overview: every machine axis of the catalogue at a glance, sorted by what needs attention first
(``guideway fleet``, docs/fleet.md "Fleet overview")."""
