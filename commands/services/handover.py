"""For transports that hand commands over one at a time (the Wave Glider bridge): mark sent,
fail unsent, complete, note."""

from __future__ import annotations

import datetime as dt

from django.db import transaction
from django.utils import timezone

from commands.errors import CommandError
from commands.lifecycle import Status
from commands.models import Command, CommandEvent
from commands.services._transition import _storable_text, _transition


@transaction.atomic
def command_mark_sent(
    *,
    command: Command,
    actor: str,
    detail: str = "",
    now: dt.datetime | None = None,
    tid: int | None = None,
    src_task: int | None = None,
    src_board: int | None = None,
) -> bool:
    """queued → sent for a command being handed over now; False if it moved first.

    The conditional UPDATE (see :func:`_transition`) makes a racing cancel, supersede or
    expiry win cleanly: the caller must then not hand the command over. ``tid``, ``src_task``
    and ``src_board`` name the request that took it (kept on the sent event).
    """
    request = {"tid": tid, "src_task": src_task, "src_board": src_board}
    return _transition(
        command, Status.SENT, now=now or timezone.now(), actor=actor, detail=detail, fields=request
    )


@transaction.atomic
def command_fail_unsent(
    *,
    command: Command,
    reason: str,
    actor: str,
    now: dt.datetime | None = None,
    cc_reason: str = "",
) -> bool:
    """Fail a queued command its transport refuses to send, with the reason; False if it moved.

    The lifecycle (docs/api.md) has no queued → failed, so the command passes through sent in
    this one transaction: nobody outside ever sees it sent, and the sent event says that
    nothing was handed over. ``cc_reason`` (the failed event's) is the refusal as a reply
    says it.
    """
    now = now or timezone.now()
    if not _transition(
        command, Status.SENT, now=now, actor=actor, detail=f"not handed over: {reason}"
    ):
        return False
    return _transition(
        command,
        Status.FAILED,
        now=now,
        actor=actor,
        detail=reason,
        fields={"cc_reason": _storable_text(cc_reason)},
    )


@transaction.atomic
def command_complete(
    *,
    command: Command,
    status: str,
    detail: str,
    actor: str,
    now: dt.datetime | None = None,
    cc_code: int | None = None,
    cc_reason: str = "",
) -> bool:
    """Record the final answer on a handed-over command: ``done`` or ``failed``.

    ``done`` goes sent → acknowledged → done (a single ACK both accepts and completes it),
    ``failed`` goes straight to failed. Returns False, changing nothing, when the command is
    no longer sent or acknowledged (an operator cancelled it meanwhile, or it already ended).
    ``cc_code`` and ``cc_reason``, the answer itself, go on its events beside ``detail``.
    """
    target = Status(status)
    if target not in (Status.DONE, Status.FAILED):
        raise CommandError("status must be done or failed", field="status")
    now = now or timezone.now()
    answer = {"cc_code": cc_code, "cc_reason": _storable_text(cc_reason)}
    command.refresh_from_db(fields=["status"])
    if command.status == Status.SENT and target == Status.DONE:
        if not _transition(
            command, Status.ACKNOWLEDGED, now=now, actor=actor, detail=detail, fields=answer
        ):
            return False
    if command.status not in (Status.SENT, Status.ACKNOWLEDGED):
        return False
    return _transition(command, target, now=now, actor=actor, detail=detail, fields=answer)


def command_note(
    *, command: Command, detail: str, actor: str, now: dt.datetime | None = None
) -> CommandEvent:
    """Log what happened to a command without changing its status (from = to = current).

    For facts an operator must see in the command's log that are not transitions: a late
    answer after a timeout, a retry answered again after a restart.
    """
    command.refresh_from_db(fields=["status"])
    return CommandEvent.objects.create(
        command=command,
        at=now or timezone.now(),
        from_status=command.status,
        to_status=command.status,
        actor=actor[:150],
        detail=_storable_text(detail),
    )
