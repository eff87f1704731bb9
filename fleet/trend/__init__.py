"""The trend of a headline value over the catalogued runs of a machine axis (``guideway trend``): the
weighted least-squares fit, its limit crossing and steps (fit.py), read from the catalogue
(of_catalog.py), and its HTML report (report.py)."""
