"""Vessel kinds (DESIGN §3). Pure: the models, the command catalog and the edge side share them."""

from __future__ import annotations

MAVLINK = "mavlink"  # ArduPilot Rover boats such as the SPAB
WAVE_GLIDER = "wave_glider"  # Liquid Robotics Wave Gliders (Level 2 + SMS)
