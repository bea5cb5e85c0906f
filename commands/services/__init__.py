"""Command writes: enqueue, claim (deliver), ack, cancel, expire. Every transition is recorded.

One module per sub-domain; the public names are re-exported here, so callers import them from
``commands.services``. Patch a name where it is looked up (its module), not here."""

from commands.errors import CatalogError, CommandError, CommandNotFound, TransitionError
from commands.services.delivery import (
    LEGACY_DELIVERY_NOTE,
    LEGACY_KINDS,
    command_ack,
    command_cancel,
    command_claim_open,
    command_deliver_legacy,
    command_expire_due,
    command_relay_claim,
    command_withdraw_queued,
)
from commands.services.enqueue import command_enqueue, command_validate, vessel_context
from commands.services.fences import fence_send, fence_set_for, fence_set_params
from commands.services.handover import (
    command_complete,
    command_fail_unsent,
    command_mark_sent,
    command_note,
)
from commands.services.missions import mission_send, mission_send_problems
from commands.services.reported import (
    CREATED_BY_MAX,
    REPORTED_ACTOR,
    REPORTED_SOURCE_ALIASES,
    REPORTED_SOURCES,
    command_record_reported,
    command_reports_record,
)

__all__ = [
    "CREATED_BY_MAX",
    "LEGACY_DELIVERY_NOTE",
    "LEGACY_KINDS",
    "REPORTED_ACTOR",
    "REPORTED_SOURCES",
    "REPORTED_SOURCE_ALIASES",
    "CatalogError",
    "CommandError",
    "CommandNotFound",
    "TransitionError",
    "command_ack",
    "command_cancel",
    "command_claim_open",
    "command_complete",
    "command_deliver_legacy",
    "command_enqueue",
    "command_expire_due",
    "command_fail_unsent",
    "command_mark_sent",
    "command_note",
    "command_record_reported",
    "command_relay_claim",
    "command_reports_record",
    "command_validate",
    "command_withdraw_queued",
    "fence_send",
    "fence_set_for",
    "fence_set_params",
    "mission_send_problems",
    "mission_send",
    "vessel_context",
]
