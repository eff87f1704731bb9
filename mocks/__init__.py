"""Simulated devices that speak the real wire protocols.

Emulators are independent implementations written from the protocol documents
(``protocols.md``, ``docs/modbus-map.md``); they never import ``drivers``.  One
:class:`~mocks.world.World` feeds every emulator so moving the simulated gauge
block changes the interferometer and the sensor readings consistently.
"""
