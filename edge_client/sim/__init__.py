"""An ArduPilot-Rover-like MAVLink vehicle simulator (see :mod:`edge_client.sim.rover`)."""

from edge_client.sim.rover import RoverSim

__all__ = ["RoverSim"]
