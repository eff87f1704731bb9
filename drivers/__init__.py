"""Device drivers: pure protocol codecs, transports and driver classes.

Layering: ``drivers`` imports neither ``acquisition``, ``processing``, ``tui``
nor ``mocks``. Every driver opens its port through ``serial.serial_for_url`` (or
the pymodbus client) so the same code talks to real hardware and to emulators.
"""
