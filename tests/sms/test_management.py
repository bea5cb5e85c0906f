"""authorise_number, deauthorise_number and sms_inject from a shell."""

from __future__ import annotations

import datetime as dt
from io import StringIO

import pytest
from django.core.management import CommandError, base, call_command, execute_from_command_line

from commands.models import Command
from sms.management.commands.sms_inject import NOT_ANSWERED
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


def test_authorise_number_positions_on_off_and_left_alone(glider: Vessel) -> None:
    args = ("authorise_number", SKIPPER, "--vessel", "glider", "--role", "query", "--name", "S")
    _, said = run(*args, "--positions")
    assert "receives positions" in said
    run(*args)  # not given: unchanged
    assert AuthorisedNumber.objects.get().receives_positions is True
    run(*args, "--no-positions")
    assert AuthorisedNumber.objects.get().receives_positions is False


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


def not_answered(*args: str) -> tuple[str, str]:
    """sms_inject that must refuse: (what it printed, why on stderr)."""
    out = StringIO()
    with pytest.raises(CommandError) as refused:
        call_command("sms_inject", *args, stdout=out, stderr=StringIO())
    assert refused.value.returncode == NOT_ANSWERED
    return out.getvalue(), str(refused.value)


def test_sms_inject_says_on_stderr_why_a_stranger_gets_no_reply_and_exits_3(
    glider: Vessel, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    # As from a shell (argv, exit status, stderr); only its closing of every connection on
    # the way out is left out, which would close the test database under the test.
    monkeypatch.setattr(base.connections, "close_all", lambda: None)
    argv = ["manage.py", "sms_inject", "--vessel", "glider", "--from", "+61400000001",
            "--text", "#STATUS"]  # fmt: skip
    with pytest.raises(SystemExit) as exited:
        execute_from_command_line(argv)
    assert exited.value.code == NOT_ANSWERED
    out, err = capsys.readouterr()
    assert out == ""
    assert err.endswith(  # after any system check warnings
        "CommandError: no reply: +61400000001 is not an authorised number (logged as a stranger)\n"
    )
    assert SmsMessage.objects.get().outcome == "stranger"


@pytest.mark.parametrize(
    ("setup", "text", "reason"),
    [
        (["deauthorise_number", SKIPPER], "#STATUS", "no reply: refused (number inactive)"),
        (["authorise_number", SKIPPER, "--vessel", "glider", "--role", "control", "--name", "S",
          "--expires", "2020-01-01"], "#STATUS",
         "no reply: refused (authorisation expired 2020-01-01 00:00 UTC)"),
        (["authorise_number", SKIPPER, "--vessel", "spab", "--role", "control", "--name", "S"],
         "#STATUS", "no reply: refused (not authorised for glider)"),
        (["authorise_number", SKIPPER, "--vessel", "glider", "--role", "query", "--name", "S"],
         "#FHEAD 230", "no reply: refused (query role: may not command)"),
    ],
)  # fmt: skip
def test_sms_inject_names_why_a_known_number_is_refused(
    glider: Vessel, vessel_a: Vessel, setup: list[str], text: str, reason: str
) -> None:
    run("authorise_number", SKIPPER, "--vessel", "glider", "--role", "control", "--name", "S")
    run(*setup)
    out, err = not_answered("--vessel", "glider", "--from", SKIPPER, "--text", text)
    assert (out, err) == ("", reason)


def test_sms_inject_prints_the_rate_limit_notice_once_then_says_why_it_is_silent(
    glider: Vessel, settings: object
) -> None:
    settings.SMS_RATE_LIMIT = 1  # type: ignore[attr-defined]
    run("authorise_number", SKIPPER, "--vessel", "glider", "--role", "control", "--name", "S")
    args = ("--vessel", "glider", "--from", SKIPPER, "--text", "#STATUS")
    assert run("sms_inject", *args)[0].startswith("#STATUS pos unknown")
    out, err = not_answered(*args)
    assert out.startswith("SMS limit reached (1 per 10 min): texts are not answered until ")
    assert out.endswith(" UTC.\n")
    assert err.startswith("rate limited (more than 1 in 600 s; answered again from ")
    assert err.endswith("UTC); the notice printed is its one reply")
    out, err = not_answered(*args)
    assert out == ""
    assert err.endswith("UTC); the number was told once already")


def test_sms_inject_says_a_delivery_handled_before_is_not_answered_again(glider: Vessel) -> None:
    run("authorise_number", SKIPPER, "--vessel", "glider", "--role", "control", "--name", "S")
    args = ("--vessel", "glider", "--from", SKIPPER, "--text", "#FHEAD 230",
            "--modem-timestamp", "2026-11-23T08:00:00+08:00")  # fmt: skip
    assert run("sms_inject", *args)[0] == "#FHEAD 230 QUEUED\n"
    out, err = not_answered(*args)
    first = SmsMessage.objects.get(direction="in")
    assert out == ""
    assert err.startswith(f"no reply: delivered before (SMS {first.pk}, received ")
    assert err.endswith(" UTC, accepted); handled once")
    assert Command.objects.count() == 1
    with pytest.raises(CommandError, match="is not a date-time with an offset"):
        run("sms_inject", *args[:-1], "2026-11-23 08:00")


def test_sms_inject_names_an_unknown_vessel(db: None) -> None:
    with pytest.raises(CommandError, match="no vessel 'nowhere'"):
        run("sms_inject", "--vessel", "nowhere", "--from", SKIPPER, "--text", "#STATUS")
