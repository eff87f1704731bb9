"""Compensation tables for CNC controllers: error-curve models, table building, residual
after compensation, one text writer per controller, and each controller's compensation stage
(stage*.py: a written file read and applied as that controller does; docs/compensation.md).

Pure functions, arrays in and out; positions in mm (deg), errors in um (arcsec), errors are
e = actual − commanded.  Each writer converts errors to its controller's stored quantity.
"""
