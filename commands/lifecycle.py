"""Command lifecycle (DESIGN §4): statuses and the legal transitions between them. Pure."""

from __future__ import annotations

from enum import StrEnum

from commands.errors import TransitionError


class Status(StrEnum):
    QUEUED = "queued"
    SENT = "sent"
    ACKNOWLEDGED = "acknowledged"
    DONE = "done"
    FAILED = "failed"
    CANCELLED = "cancelled"
    SUPERSEDED = "superseded"
    EXPIRED = "expired"


# Statuses the vessel still has to see (the boat poll offers these again until acked).
OPEN = (Status.QUEUED, Status.SENT)
FINAL = frozenset({Status.DONE, Status.FAILED, Status.CANCELLED, Status.SUPERSEDED, Status.EXPIRED})

TRANSITIONS: dict[Status, frozenset[Status]] = {
    Status.QUEUED: frozenset({Status.SENT, Status.CANCELLED, Status.SUPERSEDED, Status.EXPIRED}),
    # A boat may report done/failed without an explicit acknowledged first, and superseded
    # for a command it replaced with a newer one (before or after it got under way).
    Status.SENT: frozenset(
        {Status.ACKNOWLEDGED, Status.DONE, Status.FAILED, Status.CANCELLED, Status.SUPERSEDED}
    ),
    Status.ACKNOWLEDGED: frozenset({Status.DONE, Status.FAILED, Status.SUPERSEDED}),
    Status.DONE: frozenset(),
    Status.FAILED: frozenset(),
    Status.CANCELLED: frozenset(),
    Status.SUPERSEDED: frozenset(),
    Status.EXPIRED: frozenset(),
}

# Statuses a vessel may report in an ack, in the order they happen.
ACK_STATUSES = (Status.ACKNOWLEDGED, Status.DONE, Status.FAILED, Status.SUPERSEDED)
_ACK_RANK = {
    Status.SENT: 0,
    Status.ACKNOWLEDGED: 1,
    Status.DONE: 2,
    Status.FAILED: 2,
    Status.SUPERSEDED: 2,
}


def can_transition(current: Status, target: Status) -> bool:
    return target in TRANSITIONS[current]


def check_transition(current: Status, target: Status) -> None:
    if not can_transition(current, target):
        raise TransitionError(current, target)


def ack_is_stale(current: Status, reported: Status) -> bool:
    """True when an ack repeats or trails what the server already knows.

    Acks travel through a store-and-forward outbox and may arrive twice or out of order;
    `acknowledged` after `done` is old news, not an error. A different final status
    (`failed` after `done`) is a conflict and is not stale.
    """
    if current == reported:
        return True
    return (
        current in _ACK_RANK and reported in _ACK_RANK and _ACK_RANK[reported] < _ACK_RANK[current]
    )
