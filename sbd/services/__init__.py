"""Writes of the SBD app: deliveries in (inbound), commands out (outbound)."""

from sbd.services.inbound import Received, sbd_receive
from sbd.services.outbound import sbd_queue_command, sbd_send_command, sbd_send_queued

__all__ = ["Received", "sbd_queue_command", "sbd_receive", "sbd_send_command", "sbd_send_queued"]
