"""The simulated rig: the only code that imports ``mocks``.

Sensor emulators behind real pseudo-terminals, the interferometer controller on loopback Modbus, the
simulated machine axis of a positioning run, scenario files and their effects, and the synthetic
runs of ``guideway simulate``.  Everything downstream opens these endpoints with the real drivers.
"""
