"""Laser-interferometer controller over Modbus (TCP or RTU)."""

from .controller import InterferometerController
from .register_map import RegisterMap, load_register_map

__all__ = ["InterferometerController", "RegisterMap", "load_register_map"]
