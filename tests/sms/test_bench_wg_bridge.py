"""bench.wg_bridge's rounds each queue a command, even two landing in the same second."""

from __future__ import annotations

import pytest

from bench.wg_bridge import NUMBER, ROUNDS, round_text
from commands.models import Command
from sms.services import authorised_number_authorise, sms_handle_incoming
from tests.support import BASE
from vessels.models import Vessel

pytestmark = pytest.mark.django_db


def test_rounds_in_the_same_second_are_not_taken_for_re_deliveries(glider: Vessel) -> None:
    # The modem's time stamp has whole seconds: one phone's same text in the same second is
    # one delivery read twice. The benchmark's rounds must not look like that, or a round's
    # samples vanish.
    authorised_number_authorise(number=NUMBER, vessels=[glider], role="control", name="Bench")
    outcomes = [
        sms_handle_incoming(vessel=glider, number=NUMBER, text=round_text(n),
                            received_at=BASE, modem_timestamp=BASE)
        for n in range(ROUNDS)
    ]  # fmt: skip
    assert [outcome.duplicate for outcome in outcomes] == [False] * ROUNDS
    assert Command.objects.count() == ROUNDS
