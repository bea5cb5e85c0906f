"""Shoreside edge client: the program on the boat's Raspberry Pi.

It sits between ArduPilot (MAVLink over serial, or UDP/TCP for simulators) and the shore server
(the boat API, docs/api.md) and replaces the original SPAB boat's client (telemetry manager, Mavlink
manager, F2414 modem class, started by cron through a respawn script).

Standalone on purpose: it never imports Django, and its only third-party dependencies are
pymavlink, pyserial and requests: the project's ``[edge]`` extra (``edge_client/requirements.txt``
is the same list).
"""

__version__ = "0.1.0"
