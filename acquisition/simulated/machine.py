"""The simulated machine axis of a positioning run: it runs exactly the set-up's ISO 230-2 cycle
behind a Modbus TCP interferometer controller, with the in-position handshake of the set-up's
trigger mode (docs/modbus-map.md) and the errors of ``[simulation]`` or of a scenario."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from mocks.faults import FaultPlan
from mocks.interferometer import InterferometerEmulator, ModbusServerThread, start_controller
from mocks.live_controller import LiveOffsetController, start_live_controller
from mocks.machine_axis import AxisErrors, InPositionRegisters, LinearOptics, MachineAxis, MachineStop
from mocks.world import Environment
from processing.compensation.stage import Compensator, ControllerTable
from processing.environment import EnvironmentSettings
from saved_runs.errors import UserError

from ..setup.positioning import PositioningSetup, SimulatedAxisSetup
from .effects import scenario_axis
from .faults import parse_faults

if TYPE_CHECKING:
    from .scenario import Scenario


@dataclass
class SimulatedMachine:
    """A simulated machine axis running the set-up's cycle behind a Modbus TCP interferometer controller."""

    axis: MachineAxis
    controller_url: str
    _modbus: ModbusServerThread
    faults: FaultPlan | None = None
    # live compensation (docs/compensation.md): the controller's external-offset interface and its server
    live_controller: LiveOffsetController | None = None
    _live_server: ModbusServerThread | None = None

    @property
    def live_url(self) -> str:
        """The live-compensation interface's Modbus TCP URL ("" without live compensation)."""
        return self._live_server.url if self._live_server is not None else ""

    def cycle_start(self, **_: Any) -> None:
        """What the simulated technician does when asked to press Cycle Start."""
        self.axis.cycle_start()

    def close(self) -> None:
        self._modbus.stop()
        if self._live_server is not None:
            self._live_server.stop()


HANDSHAKE = {"in-position": "ack", "manual": "cycle-start", "stability": "timed"}


def _environment(sim: SimulatedAxisSetup) -> Environment:
    return Environment(air_temp_c=sim.air_temp_c, air_pressure_hpa=sim.air_pressure_hpa,
                       humidity_pct=sim.humidity_pct, material_temp_c=sim.material_temp_c,
                       drift_c_per_h=sim.drift_c_per_h)


def axis_errors(setup: PositioningSetup, noise: bool) -> AxisErrors:
    sim = setup.simulation
    reversal = ((sim.reversal_amplitude, sim.reversal_wavelength, 0.0),) if sim.reversal_amplitude else ()
    if setup.axis_type == "rotary" and sim.errors() == SimulatedAxisSetup().errors():
        # rotary defaults (arcsec): a once-per-revolution error, a 90-tooth worm's periodic error
        return AxisErrors(pitch=((4.0, 360.0, 0.7),), slope_per_m=0.0, backlash=2.0, periodic=1.0,
                          periodic_period=4.0, thermal_per_m_per_h=0.0, noise=0.3 if noise else 0.0,
                          reversal=reversal)
    return AxisErrors(pitch=((sim.pitch_amplitude, sim.pitch_wavelength, 0.4),), slope_per_m=sim.slope_per_m,
                      backlash=sim.backlash, periodic=sim.periodic, periodic_period=sim.periodic_period,
                      thermal_per_m_per_h=sim.thermal_per_m_per_h, noise=sim.noise if noise else 0.0,
                      reversal=reversal)


def optics_of(setup: PositioningSetup) -> LinearOptics:
    """The controller's reading model from the set-up's [environment], read the way processing reads it."""
    try:
        env = EnvironmentSettings.from_dict(setup.environment.to_dict())
    except ValueError as exc:
        raise UserError(f"[environment]: {exc}") from None
    return LinearOptics(expansion_ppm_per_k=env.expansion_ppm_per_k,
                        refractive_index_assumed=env.refractive_index_assumed or 1.0,
                        wavelength_nm=env.wavelength_nm, co2_ppm=env.co2_ppm, index_equation=env.index_equation,
                        dead_path_mm=env.dead_path_mm, readings_compensated=env.readings_compensated)


def start_simulated_machine(setup: PositioningSetup, *, seed: int = 0, noise: bool = True,
                            faults: str | None = None, start_at: int = 0, device_id: int = 1,
                            scenario: Scenario | None = None,
                            compensation: ControllerTable | None = None,
                            live_compensation: bool = False) -> SimulatedMachine:
    """Start a machine axis that runs exactly the set-up's cycle, read by a Modbus TCP controller
    (at unit id ``device_id``).

    The in-position handshake follows the trigger mode: the PLC waits for the tool's acknowledge
    (in-position), for Cycle Start (manual, M00 at each target) or for the dwell time (stability).
    ``start_at``: the program is restarted at the block of that measured stop (0-based; resume).
    ``[simulation] plc_bits_left_set`` / ``program_start_s``: a PLC that left *in position* and
    *cycle finished* set from an earlier cycle, and a program that reaches its first block that long
    after Cycle Start (docs/modbus-map.md).
    ``scenario``: a positioning scenario replaces the set-up's ``[simulation]`` errors and conditions
    by its effects, conditions, angular motion and noise (its time-dependent effects run on the wall
    clock, as the run's ``time_s`` does).
    ``compensation``: the table the simulated controller applies (processing/compensation/stage.py):
    its correction is added to every commanded position, the direction from the commanded motion,
    the axis referenced (homed) before the program starts.
    ``live_compensation``: the controller serves the live-compensation interface (mocks/live_controller.py,
    its own Modbus TCP server, :attr:`SimulatedMachine.live_url`) and adds the live offset to every
    commanded position (a compensator must run against it; without one the offset stays 0).
    """
    plan = parse_faults(faults)
    stops = [MachineStop(s.position, s.target_index, s.run, s.direction) for s in setup.stops()]
    if scenario is not None:
        if setup.axis_type != "linear":
            raise UserError("a scenario simulates a linear axis; the set-up is for a rotary one")
        model: dict[str, Any] = {**scenario_axis(scenario, noise), "wall_clock_effects": True}
    else:
        model = {"errors": axis_errors(setup, noise), "environment": _environment(setup.simulation)}
    if compensation is not None and live_compensation:
        raise UserError("a compensation table and live compensation at once: choose one")
    live = LiveOffsetController(rotary=setup.axis_type == "rotary", start=setup.datum,
                                faults=plan) if live_compensation else None
    compensator: Any = Compensator(compensation, start=setup.datum) if compensation is not None else live
    axis = MachineAxis(stops, rotary=setup.axis_type == "rotary", feed_per_min=setup.feed_per_min,
                       dwell_s=setup.trigger.dwell_s, handshake=HANDSHAKE[setup.trigger.mode], datum=setup.datum,
                       seed=seed, optics=optics_of(setup), bits_left_set=setup.simulation.plc_bits_left_set,
                       program_start_s=setup.simulation.program_start_s, compensator=compensator, **model)
    emulator = InterferometerEmulator(axis, word_order=setup.devices.word_order, faults=plan,  # type: ignore[arg-type]
                                      extension=InPositionRegisters(axis, setup.devices.word_order))
    if start_at:
        measured = [k for k, s in enumerate(stops) if s.target_index]
        axis.index = measured[min(start_at, len(measured) - 1)] - 1  # restart: the next block is that target
        axis.commanded = stops[axis.index].position
        if compensator is not None and live is None:  # the controller's state as the program left it: replay
            for stop in stops[:axis.index + 1]:
                axis.correction = compensator.move_to(stop.position)
    modbus = start_controller(emulator, device_id=device_id)
    live_server = start_live_controller(live) if live is not None else None
    return SimulatedMachine(axis, modbus.url, modbus, plan, live, live_server)
