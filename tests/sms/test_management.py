"""authorise_number, deauthorise_number and sms_inject from a shell."""

from __future__ import annotations

import datetime as dt
from io import StringIO

import pytest
from django.core.management import CommandError, call_command

from commands.models import Command
from sms.models import AuthorisedNumber, SendStatus, SmsMessage
from vessels.models import Vessel

SKIPPER = "+61412345678"


def run(*args: str) -> tuple[str, str]:
    out, err = StringIO(), StringIO()
    call_command(*args, stdout=out, stderr=err)
    return out.getvalue(), err.getvalue()


def test_authorise_number_creates_a_normalised_entry(glider: Vessel, vessel_a: Vessel) -> None:
    out, _ = run("authorise_number", "0412 345 678", "--vessel", "glider", "--vessel", "spab",
                 "--role", "control", "--name", "Skipper", "--expires", "2027-01-31")  # fmt: skip
    assert out.strip() == SKIPPER
    entry = AuthorisedNumber.objects.get()
    assert (entry.number, entry.role, entry.name, entry.active) == (
        SKIPPER,
        "control",
        "Skipper",
        True,
    )
    assert set(entry.vessels.all()) == {glider, vessel_a}
    assert entry.expires_at == dt.datetime(2027, 1, 31, tzinfo=dt.UTC)


def test_authorise_number_again_replaces_vessels_and_reactivates(
    glider: Vessel, vessel_a: Vessel
) -> None:
    run("authorise_number", SKIPPER, "--vessel", "glider", "--role", "control", "--name", "S")
    run("deauthorise_number", SKIPPER)
    run("authorise_number", "+61 412 345 678", "--vessel", "spab", "--role", "query", "--name", "S")
    entry = AuthorisedNumber.objects.get()
    assert (entry.active, entry.role, list(entry.vessels.all())) == (True, "query", [vessel_a])


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["12345", "--vessel", "glider"], "is not a valid phone number"),
        ([SKIPPER, "--vessel", "nowhere"], "no vessel 'nowhere'"),
        ([SKIPPER, "--vessel", "glider", "--expires", "31/01/2027"], "is not a date"),
    ],
)
def test_authorise_number_explains_what_is_wrong(
    glider: Vessel, args: list[str], message: str
) -> None:
    with pytest.raises(CommandError, match=message):
        run("authorise_number", *args, "--role", "control", "--name", "X")
    assert not AuthorisedNumber.objects.exists()


def test_deauthorise_number_keeps_the_entry_inactive(glider: Vessel) -> None:
    run("authorise_number", SKIPPER, "--vessel", "glider", "--role", "control", "--name", "S")
    out, _ = run("deauthorise_number", "0412-345-678")
    assert out.strip() == SKIPPER
    assert AuthorisedNumber.objects.get().active is False
    with pytest.raises(CommandError, match="is not an authorised number"):
        run("deauthorise_number", "+61400000001")


def test_sms_inject_prints_the_reply_one_sms_per_line(glider: Vessel) -> None:
    run("authorise_number", SKIPPER, "--vessel", "glider", "--role", "control", "--name", "S")
    out, err = run("sms_inject", "--vessel", "glider", "--from", "0412 345 678",
                   "--text", "#FHEAD 230\n#FSEQ 1 1 4")  # fmt: skip
    assert out == "#FHEAD 230 QUEUED; #FSEQ 1 1 4 ERR not enabled on this glider\n"
    assert err == ""
    command = Command.objects.get()
    assert (command.source, command.created_by) == ("sms", SKIPPER)
    reply = SmsMessage.objects.get(direction="out")
    assert reply.status == SendStatus.NOT_SENT  # shown, never sent by the modem


def test_sms_inject_with_send_leaves_the_reply_for_the_modem(glider: Vessel) -> None:
    run("authorise_number", SKIPPER, "--vessel", "glider", "--role", "query", "--name", "S")
    out, _ = run(
        "sms_inject", "--vessel", "glider", "--from", SKIPPER, "--text", "#LIGHT", "--send"
    )
    assert out == "#LIGHT unknown\n"
    assert SmsMessage.objects.get(direction="out").status == SendStatus.PENDING


def test_sms_inject_prints_nothing_at_all_for_a_stranger(glider: Vessel) -> None:
    out, err = run(
        "sms_inject", "--vessel", "glider", "--from", "+61400000001", "--text", "#STATUS"
    )
    assert (out, err) == ("", "")
    assert SmsMessage.objects.get().outcome == "stranger"


def test_sms_inject_names_an_unknown_vessel(db: None) -> None:
    with pytest.raises(CommandError, match="no vessel 'nowhere'"):
        run("sms_inject", "--vessel", "nowhere", "--from", SKIPPER, "--text", "#STATUS")
