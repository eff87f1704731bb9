"""CNC compensation tables from a positioning run (``guideway export``): options, the table grid,
the controller files, and the residual after compensation of every model."""
