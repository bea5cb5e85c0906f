"""The SMS log upload's one service (sms_log_upload): the entries' rules are its own, not the
boat API's, and every SmsMessage it (or the handle path) writes passes the model's checks."""

from __future__ import annotations

import datetime as dt
from typing import Any

import pytest
from django.core.exceptions import ValidationError

from sms.models import Outcome, SmsMessage
from sms.services import sms_handle_incoming, sms_log_entry_store, sms_log_upload
from tests.support import BASE
from vessels.batch import Unreadable
from vessels.models import Vessel

pytestmark = pytest.mark.django_db

NOW = BASE + dt.timedelta(hours=1)


def entry(origin: str, **changes: Any) -> dict[str, Any]:
    """An incoming entry as the boat API reads it (datetimes, not strings)."""
    base = {
        "id": origin,
        "direction": "in",
        "number": "+61412345678",
        "text": "#STATUS",
        "created_at": BASE,
        "received_at": BASE,
        "outcome": "accepted",
    }
    return base | changes


def stored() -> set[str]:
    return set(SmsMessage.objects.values_list("origin_id", flat=True))


def test_the_service_keeps_the_time_and_direction_rules_whoever_calls_it(glider: Vessel) -> None:
    entries = [
        entry("a"),
        entry("b", created_at=dt.datetime(2001, 1, 1, tzinfo=dt.UTC)),  # a reset clock
        entry("c", status="sent"),  # an incoming SMS has no send status
        entry("d", direction="out", outcome=""),  # an outgoing one needs it
        entry("e", direction="out", status="sent", outcome="accepted"),  # and has no outcome
        Unreadable({"entry": ["not an object"]}),
        entry("a"),  # again in the same batch
        entry("f"),
    ]
    answer = sms_log_upload(vessel=glider, entries=entries, now=NOW).as_dict()
    assert (answer["accepted"], answer["duplicates"]) == (2, 1)
    named = [(r["index"], *r["errors"]) for r in answer["rejected"]]
    assert named == [(1, "created_at"), (2, "status"), (3, "status"), (4, "outcome"), (5, "entry")]
    assert stored() == {"a", "f"}
    again = sms_log_upload(vessel=glider, entries=[entry("a")], now=NOW).as_dict()
    assert again == {"accepted": 0, "duplicates": 1, "rejected": []}


def test_an_entry_the_model_refuses_is_rejected_by_index_and_the_others_kept(
    glider: Vessel,
) -> None:
    # Past the rules but not the model's choices: stored as given before full_clean ran.
    refused = entry("b", outcome="no such outcome")
    with pytest.raises(ValidationError):
        sms_log_entry_store(vessel=glider, entry=refused)
    assert stored() == set()
    answer = sms_log_upload(vessel=glider, entries=[entry("a"), refused], now=NOW).as_dict()
    assert answer["accepted"] == 1
    assert [(r["index"], *r["errors"]) for r in answer["rejected"]] == [(1, "outcome")]
    assert stored() == {"a"}


def test_an_sms_without_a_sender_is_logged_as_a_stranger(glider: Vessel) -> None:
    # The model's checks run on the handle path too: a blank sender is a stranger to log,
    # not a refused row.
    result = sms_handle_incoming(vessel=glider, number=" ", text="#STATUS", received_at=BASE)
    assert (result.outcome, result.message.number, result.replies) == (Outcome.STRANGER, "", ())
    assert SmsMessage.objects.get().number == ""
