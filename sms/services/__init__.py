"""SMS writes: the one entry point for an incoming SMS, the outgoing queue the modem loop sends,
and the authorised numbers (docs/sms.md: only active authorised numbers with the right role are
answered; everything else is logged and not answered).

One module per sub-domain: ``incoming`` (the handle path), ``replies`` (when and what is
answered), ``outgoing`` (the modem's queue), ``positions`` (the glider's position SMS),
``numbers``, ``shore`` (the shore link's uploads), ``route`` (a shore command to its glider by
SMS). The public names are re-exported here; patch a name where it is looked up (its module),
not here.
"""

from sms.services._common import DETAIL_MAX, TEXT_STORE_MAX
from sms.services.incoming import SmsOutcome, shipped_table, sms_handle_incoming
from sms.services.numbers import (
    authorised_number_authorise,
    authorised_number_deauthorise,
    authorised_number_delete,
    authorised_number_save,
    number_normalise,
    validation_message,
)
from sms.services.outgoing import sms_mark_failed, sms_mark_sent, sms_outgoing_pending
from sms.services.positions import (
    LastRound,
    PositionRound,
    position_last_round,
    position_report,
    position_state,
    sms_position_queue,
)
from sms.services.replies import sms_replies_due
from sms.services.route import sms_send_command
from sms.services.shore import (
    SMS_TIMES,
    NumbersReplaced,
    authorised_numbers_replace,
    sms_log_check,
    sms_log_entry_store,
    sms_log_upload,
)

__all__ = [
    "DETAIL_MAX",
    "LastRound",
    "PositionRound",
    "SMS_TIMES",
    "TEXT_STORE_MAX",
    "NumbersReplaced",
    "SmsOutcome",
    "authorised_number_authorise",
    "authorised_number_deauthorise",
    "authorised_number_delete",
    "authorised_number_save",
    "authorised_numbers_replace",
    "number_normalise",
    "position_last_round",
    "position_report",
    "position_state",
    "shipped_table",
    "sms_handle_incoming",
    "sms_log_check",
    "sms_log_entry_store",
    "sms_log_upload",
    "sms_mark_failed",
    "sms_mark_sent",
    "sms_outgoing_pending",
    "sms_position_queue",
    "sms_replies_due",
    "sms_send_command",
    "validation_message",
]
