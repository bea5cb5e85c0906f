"""An ArduPilot-Rover-like MAVLink vehicle simulator (see :mod:`tests.sim.rover`)."""

from tests.sim.rover import RoverSim

__all__ = ["RoverSim"]
