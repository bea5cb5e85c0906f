"""The glider's end of the shore's SMS route: an SMS from an authorised number carrying the shore's
reference is the shore's command, queued under its uid (created by ``shore``), acked up by uid
through the shore link like a polled one, never queued twice whichever way it comes first.
Its reference must verify under the glider's shore key (the shore signs with that key's hash):
a forged one, or one naming a command the glider holds as another, runs nothing.
Authorisation, rate limit and replies are those of any SMS."""

from __future__ import annotations

import datetime as dt
import json
import logging
import threading
import uuid
import zlib
from collections.abc import Iterator
from typing import Any

import pytest
from django.db import connection, connections, transaction
from django.utils import timezone

from alerts.notify.sms import ModemSender
from commands.models import Command
from commands.services import command_enqueue
from edge_client.client import ACK_PATH
from edge_client.transports.base import Response
from sms import selectors
from sms.bridge.shore import CREATED_BY, ShoreLink
from sms.bridge.shore_config import ShoreConfig
from sms.bridge.sms_link import SmsLink
from sms.command_text import ALPHABET, REF_MARK, reference, render
from sms.models import Direction, Outcome, SendStatus, SmsMessage
from sms.modem import Modem, ModemConfig
from sms.modem.simulator import ModemServer, SimulatedModem
from sms.services import authorised_number_authorise, sms_handle_incoming, sms_send_command
from vessels.keys import hash_key
from vessels.models import Vessel
from vessels.services import vessel_create, vessel_key_issue

from .rig import FAST_MODEM, wait_for

SHORE_PHONE = "+61400000001"
WATCHER = "+61400000002"
STRANGER = "+61400000009"
SHORE_KEY = "ssk_the-gliders-shore-link-key"  # WG_SHORE_KEY on the glider
KEY_HASH = hash_key(SHORE_KEY)  # what the shore keeps of it, and signs with


@pytest.fixture
def shore_number(glider: Vessel) -> None:
    authorised_number_authorise(number=SHORE_PHONE, vessels=[glider], role="control",
                                name="Shore")  # fmt: skip


def texted(glider: Vessel, text: str, number: str = SHORE_PHONE, **kwargs: Any) -> Any:
    kwargs.setdefault("received_at", timezone.now())
    kwargs.setdefault("shore_key_hash", KEY_HASH)
    return sms_handle_incoming(vessel=glider, number=number, text=text, **kwargs)


class Shore:
    """The shore's side of the link: lists ``open`` at the command poll, records the rest."""

    def __init__(self) -> None:
        self.open: list[dict[str, Any]] = []
        self.posts: list[tuple[str, dict[str, Any]]] = []

    def get(self, path: str, etag: str | None = None) -> Response:
        tag = f'"{len(self.posts)}-{len(self.open)}"'
        return Response(200, {"etag": tag}, json.dumps({"commands": self.open}).encode())

    def post_json(self, path: str, body: dict[str, Any]) -> Response:
        self.posts.append((path, body))
        entries = body.get("commands") or body.get("messages") or []
        answer = {"accepted": len(entries), "duplicates": 0, "rejected": []}
        return Response(200, {}, json.dumps(answer).encode())

    def acks(self, uid: uuid.UUID) -> list[str]:
        path = ACK_PATH.format(uid=uid)
        return [body["status"] for p, body in self.posts if p == path]

    def close(self) -> None:
        pass


@pytest.fixture
def link(tmp_path, glider: Vessel) -> Iterator[tuple[ShoreLink, Shore]]:
    shore = Shore()
    config = ShoreConfig(url="http://127.0.0.1:9", key="k", outbox_path=str(tmp_path / "o.db"))
    shore_link = ShoreLink(vessel=glider, config=config, transport=shore)
    yield shore_link, shore
    shore_link.close()


@pytest.mark.django_db
def test_a_referenced_sms_queues_the_shore_command_under_its_uid(glider, shore_number):
    uid = uuid.uuid4()
    outcome = texted(glider, render("fhead", {"bearing": 230}, uid, KEY_HASH))
    (command,) = outcome.commands
    assert (command.uid, command.kind, command.params) == (uid, "fhead", {"bearing": 230})
    assert (command.created_by, command.source, command.status) == (CREATED_BY, "sms", "queued")
    assert outcome.outcome == Outcome.ACCEPTED and outcome.reply_texts == ["#FHEAD 230 QUEUED"]
    assert outcome.message.parsed[0]["shore_uid"] == str(uid)
    assert list(outcome.message.commands.all()) == [command]


@pytest.mark.django_db
def test_the_same_reference_again_is_answered_as_a_duplicate_and_not_run_twice(
    glider, shore_number
):
    uid = uuid.uuid4()
    text = render("waypoint", {"index": 2, "lat": -32.0345, "lon": 115.3326}, uid, KEY_HASH)
    texted(glider, text)
    Command.objects.filter(uid=uid).update(status="done")
    again = texted(glider, text)  # the shore sent it twice (its HTTP link was still silent)
    assert again.commands == () and Command.objects.filter(uid=uid).count() == 1
    assert again.reply_texts == ["#WAYPOINT 2 -32.0345 115.3326 DUPLICATE (done here)"]
    assert again.outcome == Outcome.ACCEPTED


@pytest.mark.django_db
def test_texted_first_then_polled_it_is_queued_once_and_its_acks_go_up_by_uid(
    glider, shore_number, link
):
    shore_link, shore = link
    uid = uuid.uuid4()
    texted(glider, render("light", {"state": "on"}, uid, KEY_HASH))
    shore_link.do_one_report_results()  # the link learns of it: no network needed
    shore.open = [{"uid": str(uid), "kind": "light", "params": {"state": "on"}}]
    assert shore_link.do_one_poll_commands() is False  # known here: nothing new queued
    assert Command.objects.filter(uid=uid).count() == 1
    assert Command.objects.get(uid=uid).status == "queued"  # still listed there: not withdrawn
    Command.objects.filter(uid=uid).update(status="sent")  # handed to the C&C
    assert shore_link.do_one_report_results() is True
    shore_link.do_one_flush_acks()
    assert shore.acks(uid) == ["acknowledged"]
    Command.objects.filter(uid=uid).update(status="done", result_detail="C&C: ACK")
    shore_link.do_one_report_results()
    shore_link.do_one_flush_acks()
    assert shore.acks(uid) == ["acknowledged", "done"]
    shore_link.do_one_report_results()  # nothing more to say, ever
    shore_link.do_one_flush_acks()
    assert shore.acks(uid) == ["acknowledged", "done"]
    reported = [c["uid"] for path, body in shore.posts for c in body.get("commands", [])]
    assert str(uid) not in reported  # a shore command is acked, never reported as the glider's


@pytest.mark.django_db
def test_polled_first_then_texted_the_sms_is_a_duplicate(glider, shore_number, link):
    shore_link, shore = link
    uid = uuid.uuid4()
    shore.open = [{"uid": str(uid), "kind": "fhead", "params": {"bearing": 90}}]
    assert shore_link.do_one_poll_commands() is True
    outcome = texted(glider, render("fhead", {"bearing": 90}, uid, KEY_HASH))
    assert outcome.commands == () and outcome.reply_texts == ["#FHEAD 90 DUPLICATE (queued here)"]
    assert Command.objects.filter(uid=uid).count() == 1
    assert Command.objects.get(uid=uid).source == "api"  # the poll's, untouched


@pytest.mark.django_db
def test_a_poll_that_read_the_uid_as_new_just_before_the_sms_queued_it_takes_it_as_known(
    glider, shore_number, link, monkeypatch
):
    """The other order of the race below: the poll looked the uid up (not here yet), then the
    SMS committed it, then the poll's insert finds it: claimed, not queued again, no error."""
    shore_link, shore = link
    uid = uuid.uuid4()
    texted(glider, render("fhead", {"bearing": 90}, uid, KEY_HASH))
    looked_up = selectors.bridge_command_vessel
    answers = iter([None])  # the first look-up happened before the SMS's commit
    monkeypatch.setattr(selectors, "bridge_command_vessel",
                        lambda *, uid: next(answers, looked_up(uid=uid)))  # fmt: skip
    shore.open = [{"uid": str(uid), "kind": "fhead", "params": {"bearing": 90}}]
    assert shore_link.do_one_poll_commands() is True  # claimed here by the poll
    assert Command.objects.filter(uid=uid).count() == 1
    assert shore_link.state.reachable is True
    Command.objects.filter(uid=uid).update(status="done")
    shore_link.do_one_report_results()
    shore_link.do_one_flush_acks()
    assert shore.acks(uid) == ["done"]


@pytest.mark.django_db
def test_strangers_and_query_numbers_cannot_send_a_shore_command(glider, shore_number):
    authorised_number_authorise(number=WATCHER, vessels=[glider], role="query", name="Watcher")
    text = render("fhead", {"bearing": 230}, uuid.uuid4(), KEY_HASH)
    stranger = texted(glider, text, number=STRANGER)
    watcher = texted(glider, text, number=WATCHER)
    assert (stranger.outcome, stranger.replies) == (Outcome.STRANGER, ())
    assert (watcher.outcome, watcher.replies) == (Outcome.REFUSED, ())
    assert not Command.objects.exists()


@pytest.mark.django_db
def test_the_shore_number_is_rate_limited_like_any(glider, shore_number, settings):
    settings.SMS_RATE_LIMIT, settings.SMS_RATE_WINDOW_S = 1, 600
    now = timezone.now()
    texted(glider, render("fhead", {"bearing": 1}, uuid.uuid4(), KEY_HASH), received_at=now)
    late = uuid.uuid4()
    held = texted(glider, render("fhead", {"bearing": 2}, late, KEY_HASH), received_at=now)
    assert held.outcome == Outcome.RATE_LIMITED and not Command.objects.filter(uid=late).exists()


ONE_COMMAND = "ERR a shore reference goes with one command (ref {uid})"


@pytest.mark.django_db
@pytest.mark.parametrize(
    ("text", "reply"),
    [
        ("#FHEAD 230; #LIGHT ON {ref}", ONE_COMMAND),
        ("#STATUS {ref}", ONE_COMMAND),
        ("#LIGHT {ref}", ONE_COMMAND),  # a query
        ("#FSEQ 1 1 4 {ref}", "#FSEQ 1 1 4 ERR not enabled on this glider"),
    ],
)
def test_a_reference_goes_with_one_command_the_glider_can_run(glider, shore_number, text, reply):
    uid = uuid.uuid4()
    words = text.removesuffix(" {ref}")
    outcome = texted(glider, text.format(ref=reference(uid, words, KEY_HASH)))
    assert outcome.commands == () and outcome.outcome == Outcome.ERROR
    assert outcome.reply_texts == [reply.format(uid=uid)]
    assert not Command.objects.exists()


@pytest.mark.django_db
def test_a_reference_to_another_vessels_command_is_refused(glider, shore_number):
    other = vessel_create(slug="glider-2", name="Wave Glider 2", kind="wave_glider")
    theirs = command_enqueue(vessel=other, kind="fhead", params={"bearing": 5})
    outcome = texted(glider, render("fhead", {"bearing": 5}, theirs.uid, KEY_HASH))
    assert outcome.reply_texts == ["#FHEAD 5 ERR ref names another vessel's command"]
    assert Command.objects.count() == 1


def crc_only_reference(uid: uuid.UUID) -> str:
    """The old reference: the uid and 12 bits of its CRC-32, which anyone can compute."""
    value = (uid.int << 12) | (zlib.crc32(uid.bytes) & 0xFFF)
    return REF_MARK + "".join(ALPHABET[(value >> (5 * i)) & 31] for i in reversed(range(28)))


def _light_on(uid: uuid.UUID) -> str:
    return render("light", {"state": "on"}, uid, KEY_HASH)


@pytest.mark.django_db
@pytest.mark.parametrize(
    ("forge", "key_here"),
    [
        pytest.param(
            lambda uid: render("light", {"state": "off"}, uid, hash_key("ssk_guess")),
            KEY_HASH,
            id="another key",
        ),
        pytest.param(
            lambda uid: _light_on(uid).replace("#LIGHT ON", "#LIGHT OFF"),
            KEY_HASH,
            id="the command changed after signing",
        ),
        pytest.param(
            lambda uid: f"#LIGHT OFF {crc_only_reference(uid)}",
            KEY_HASH,
            id="the old CRC-only reference",
        ),
        pytest.param(
            lambda uid: f"#HOLD; {_light_on(uid)}", KEY_HASH, id="a command put before a signed one"
        ),
        pytest.param(_light_on, None, id="a glider with no shore key"),
    ],
)
def test_a_reference_that_does_not_verify_runs_nothing(
    glider, shore_number, link, forge, key_here, caplog
):
    """The review's attack: a control number (or one spoofing the shore's) texts "off" under
    the uid of the shore's "on". Refused whole, nothing queued, logged; and the shore's real
    command, polled later, is queued and runs as itself."""
    shore_link, shore = link
    uid = uuid.uuid4()
    with caplog.at_level(logging.WARNING, logger="sms.services.incoming"):
        outcome = texted(glider, forge(uid), shore_key_hash=key_here)
    assert outcome.commands == () and not Command.objects.exists()
    assert outcome.outcome == Outcome.ERROR
    assert outcome.reply_texts == ["ERR ref not valid: text refused"]
    assert "shore_uid" not in outcome.message.parsed[0]
    assert any("does not verify" in r.getMessage() and SHORE_PHONE in r.getMessage()
               for r in caplog.records)  # fmt: skip
    shore.open = [{"uid": str(uid), "kind": "light", "params": {"state": "on"}}]
    assert shore_link.do_one_poll_commands() is True
    command = Command.objects.get(uid=uid)
    assert (command.kind, command.params, command.source) == ("light", {"state": "on"}, "api")


@pytest.mark.django_db
def test_a_query_number_with_a_forged_reference_is_refused_as_commanding(glider, shore_number):
    authorised_number_authorise(number=WATCHER, vessels=[glider], role="query", name="Watcher")
    forged = f"#STATUS {crc_only_reference(uuid.uuid4())}"
    outcome = texted(glider, forged, number=WATCHER)
    assert (outcome.outcome, outcome.replies) == (Outcome.REFUSED, ())


@pytest.mark.django_db
def test_a_signed_reference_to_a_uid_held_here_as_another_command_is_refused(
    glider, shore_number, link, caplog
):
    """Defence in depth: even a verified reference cannot put a second command under a uid
    the glider already holds (here polled first as "on")."""
    shore_link, shore = link
    uid = uuid.uuid4()
    shore.open = [{"uid": str(uid), "kind": "light", "params": {"state": "on"}}]
    assert shore_link.do_one_poll_commands() is True
    with caplog.at_level(logging.WARNING, logger="sms.services.incoming"):
        outcome = texted(glider, render("light", {"state": "off"}, uid, KEY_HASH))
    assert outcome.commands == () and outcome.outcome == Outcome.ERROR
    assert outcome.reply_texts == ["#LIGHT OFF ERR ref names another command here"]
    command = Command.objects.get(uid=uid)
    assert (command.params, command.status) == ({"state": "on"}, "queued")
    assert any(str(uid) in r.getMessage() and r.levelname == "WARNING" for r in caplog.records)
    same = texted(glider, _light_on(uid))  # the same command again: a duplicate, as before
    assert same.reply_texts == ["#LIGHT ON DUPLICATE (queued here)"]


@pytest.mark.django_db
def test_a_polled_command_under_a_uid_texted_here_as_another_is_acked_failed(
    glider, shore_number, link, caplog
):
    """The other way round: the SMS came first (as "off"), the poll lists "on" under its uid.
    Not taken as the same command: the shore hears that the glider holds another under it,
    and no ack of the texted one goes up under that uid."""
    shore_link, shore = link
    uid = uuid.uuid4()
    texted(glider, render("light", {"state": "off"}, uid, KEY_HASH))
    shore_link.do_one_report_results()  # the link learns of it: its acks would go up by uid
    shore.open = [{"uid": str(uid), "kind": "light", "params": {"state": "on"}}]
    with caplog.at_level(logging.ERROR, logger="sms.bridge.shore"):
        assert shore_link.do_one_poll_commands() is False
        assert shore_link.do_one_poll_commands() is False  # listed again: said once
    shore_link.do_one_flush_acks()
    path = ACK_PATH.format(uid=uid)
    ((status, detail),) = [(b["status"], b["detail"]) for p, b in shore.posts if p == path]
    assert status == "failed" and "holds a different command under this uid" in detail
    assert "light" in detail and "off" in detail
    assert any(str(uid) in r.getMessage() for r in caplog.records if r.levelname == "ERROR")
    Command.objects.filter(uid=uid).update(status="done")  # the texted one ran here
    shore_link.do_one_report_results()
    shore_link.do_one_flush_acks()
    assert shore.acks(uid) == ["failed"]  # never "done" for the shore's "on"
    assert Command.objects.filter(uid=uid).count() == 1


@pytest.mark.django_db
def test_a_poll_racing_an_sms_of_another_command_under_its_uid_acks_it_failed(
    glider, shore_number, link, monkeypatch
):
    """The race of the test above, with the SMS saying another command: the poll's insert
    finds the uid taken, and does not take what it holds for the shore's command."""
    shore_link, shore = link
    uid = uuid.uuid4()
    texted(glider, render("fhead", {"bearing": 90}, uid, KEY_HASH))
    looked_up = selectors.bridge_command_vessel
    answers = iter([None])
    monkeypatch.setattr(selectors, "bridge_command_vessel",
                        lambda *, uid: next(answers, looked_up(uid=uid)))  # fmt: skip
    shore.open = [{"uid": str(uid), "kind": "fhead", "params": {"bearing": 270}}]
    assert shore_link.do_one_poll_commands() is False
    shore_link.do_one_flush_acks()
    assert shore.acks(uid) == ["failed"]
    assert Command.objects.get(uid=uid).params == {"bearing": 90}


@pytest.mark.django_db(transaction=True)
def test_a_poll_and_an_sms_of_one_uid_at_once_queue_it_once(glider, shore_number):
    """The shore link's poll is inserting the uid, not yet committed, when the SMS comes: the
    SMS waits on the unique index, then is answered as a duplicate (its savepoint rolled back,
    the rest of its transaction kept)."""
    if connection.vendor != "postgresql":
        pytest.skip("SQLite runs one writer at a time: the two cannot overlap")
    uid = uuid.uuid4()
    polled, release, answered = threading.Event(), threading.Event(), {}

    def poll() -> None:
        try:
            with transaction.atomic():
                command_enqueue(vessel=glider, kind="light", params={"state": "on"},
                                created_by=CREATED_BY, uid=uid)  # fmt: skip
                polled.set()
                release.wait(30)
        finally:
            connections.close_all()

    def sms() -> None:
        try:
            answered["outcome"] = texted(glider, render("light", {"state": "on"}, uid, KEY_HASH))
        finally:
            connections.close_all()

    threads = [threading.Thread(target=poll), threading.Thread(target=sms)]
    threads[0].start()
    assert polled.wait(30)
    threads[1].start()
    try:
        assert wait_for(lambda: _waiting_on_a_lock() > 0, timeout_s=30)
    finally:
        release.set()
        for thread in threads:
            thread.join(30)
    outcome = answered["outcome"]
    assert outcome.reply_texts == ["#LIGHT ON DUPLICATE (queued here)"]
    assert Command.objects.filter(uid=uid).count() == 1
    assert SmsMessage.objects.filter(direction=Direction.IN, outcome=Outcome.ACCEPTED).exists()


def _waiting_on_a_lock() -> int:
    with connection.cursor() as cursor:
        cursor.execute(
            "SELECT count(*) FROM pg_stat_activity "
            "WHERE datname = current_database() AND wait_event_type = 'Lock'"
        )
        return cursor.fetchone()[0]


# -- through the modems ------------------------------------------------------------------------


@pytest.mark.slow
@pytest.mark.django_db(transaction=True)
def test_the_shores_sms_through_its_modem_is_queued_by_the_gliders_modem_link(glider, shore_number):
    """The shore's sender (the alerts' ModemSender) and the glider's SmsLink on the modem
    simulator: what one writes, the other runs, under the shore command's uid."""
    Vessel.objects.filter(pk=glider.pk).update(sms_number="+61400000077")
    glider.refresh_from_db()
    _key, raw_key = vessel_key_issue(vessel=glider)  # the shore's; the glider's WG_SHORE_KEY
    sim = SimulatedModem()
    with ModemServer(sim, "pty") as server:
        on_shore = command_enqueue(vessel=glider, kind="fhead", params={"bearing": 230})
        sender = ModemSender(ModemConfig(server.url, **FAST_MODEM))  # type: ignore[arg-type]
        try:
            sent = sms_send_command(on_shore, sender=sender)
        finally:
            sender.close()
        ((to, text),) = [(s.number, s.text) for s in sim.sent]
        assert (to, sent.status) == ("+61400000077", SendStatus.SENT)
        # The glider's database is not the shore's: there, the command exists only once the
        # SMS brings it.
        uid = on_shore.uid
        on_shore.delete()
        sim.inject(SHORE_PHONE, text, when=dt.datetime.now(dt.UTC))
        glider_link = SmsLink(
            vessel=glider, modem=Modem(ModemConfig(server.url, **FAST_MODEM)),  # type: ignore[arg-type]
            retry_base_s=0.05, shore_key_hash=hash_key(raw_key),
        )  # fmt: skip
        try:
            assert wait_for(lambda: glider_link.do_one_receive(0.2))
            assert wait_for(lambda: glider_link.do_one_send())
        finally:
            glider_link.modem.close()
    command = Command.objects.get(uid=uid)
    assert (command.created_by, command.source, command.params) == (
        "shore",
        "sms",
        {"bearing": 230},
    )
    assert [(s.number, s.text) for s in sim.sent[1:]] == [(SHORE_PHONE, "#FHEAD 230 QUEUED")]
    incoming = SmsMessage.objects.get(direction=Direction.IN)
    assert incoming.text == text and list(incoming.commands.all()) == [command]
