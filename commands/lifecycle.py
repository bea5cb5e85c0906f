"""Command lifecycle (docs/api.md, 'Delivery'): the legal transitions between statuses. Pure.

The status names, and which are open or final, are the boat–shore contract's
(``edge_client/contract/status.py``); the migrations name ``commands.lifecycle.Status``.
"""

from __future__ import annotations

from commands.errors import TransitionError
from edge_client.contract.status import ACK_STATUSES, FINAL, OPEN, Status

__all__ = [
    "ACK_STATUSES",
    "FINAL",
    "OPEN",
    "Status",
    "TRANSITIONS",
    "ack_is_stale",
    "can_transition",
    "check_transition",
]

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
