"""``guideway certificate``: the calibration certificate (PDF) of a saved run (docs/certificate.md)."""
