"""Compensation tables for CNC controllers: error-curve models, table building, residual
after compensation and one text writer per controller (docs/compensation.md).

Pure functions, arrays in and out; positions in mm (deg), errors in um (arcsec), errors are
e = actual − commanded.  Each writer converts errors to its controller's stored quantity.
"""
