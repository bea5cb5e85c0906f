"""Command status names (docs/api.md), as the boat API, the SMS replies and the pages say them.

The legal transitions between them are the server's rule (``commands/lifecycle.py``); the
names, and which of them are final, are the contract both sides and the page scripts share.
"""

from __future__ import annotations

from enum import StrEnum


class Status(StrEnum):
    QUEUED = "queued"
    SENT = "sent"
    ACKNOWLEDGED = "acknowledged"
    DONE = "done"
    FAILED = "failed"
    CANCELLED = "cancelled"
    SUPERSEDED = "superseded"
    EXPIRED = "expired"


# Statuses the vessel still has to see (the boat poll offers these again until acked); an
# operator may still cancel a command in one of them.
OPEN = (Status.QUEUED, Status.SENT)
# Statuses after which a command never changes.
FINAL = frozenset({Status.DONE, Status.FAILED, Status.CANCELLED, Status.SUPERSEDED, Status.EXPIRED})
# Not ended yet: still to be seen, or seen and under way.
UNFINISHED = frozenset(Status) - FINAL
# Statuses a vessel may report in an ack, in the order they happen.
ACK_STATUSES = (Status.ACKNOWLEDGED, Status.DONE, Status.FAILED, Status.SUPERSEDED)
