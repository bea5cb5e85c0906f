"""The shore link's parts that need no shore: its configuration, the numbers it applies, the
acks it queues for local outcomes. (Against a live shore: test_shore.py.)"""

from __future__ import annotations

import json
import threading
import time

import pytest
from django.utils import timezone

from commands.models import Command
from commands.services import command_cancel, command_enqueue
from edge_client.transports.base import Response, TransportError
from sms.bridge.shore import CREATED_BY, REPORT_PATH, REPORT_WATERMARK, SMS_PATH, ShoreLink
from sms.bridge.shore_config import ShoreConfig
from sms.models import AuthorisedNumber, SendStatus, SmsMessage
from sms.services import (
    authorised_number_authorise,
    authorised_numbers_replace,
    sms_handle_incoming,
)

ANA = "+61412345678"


def test_no_url_or_no_key_means_no_link():
    assert ShoreConfig.from_env({}) is None
    assert ShoreConfig.from_env({"WG_SHORE_URL": "https://shore.example"}) is None
    assert ShoreConfig.from_env({"WG_SHORE_KEY": "ssk_x"}) is None


def test_the_config_reads_the_environment():
    config = ShoreConfig.from_env(
        {"WG_SHORE_URL": " https://shore.example ", "WG_SHORE_KEY": "ssk_x",
         "WG_SHORE_POLL_PERIOD_S": "5", "WG_SHORE_CA_BUNDLE": "/etc/ca.pem"}
    )  # fmt: skip
    assert config is not None
    assert (config.url, config.key, config.poll_period_s) == ("https://shore.example", "ssk_x", 5)
    assert config.ca_bundle == "/etc/ca.pem" and config.push_period_s == 10


@pytest.mark.parametrize("value", ["soon", "0", "-3"])
def test_a_bad_period_is_refused_naming_the_variable(value):
    env = {"WG_SHORE_URL": "https://s", "WG_SHORE_KEY": "k", "WG_SHORE_SMS_PERIOD_S": value}
    with pytest.raises(ValueError, match="WG_SHORE_SMS_PERIOD_S"):
        ShoreConfig.from_env(env)


def entry(number: str, **extra) -> dict:
    return {"number": number, "name": "Ana", "role": "control", "active": True,
            "expires_at": None, **extra}  # fmt: skip


def test_the_shore_list_replaces_the_vessels_numbers(glider, vessel_a):
    authorised_number_authorise(number="+61400000001", vessels=[glider, vessel_a], role="control",
                                name="Gone here")  # fmt: skip
    authorised_number_authorise(number=ANA, vessels=[glider], role="query", name="Ana")
    result = authorised_numbers_replace(
        vessel=glider,
        numbers=[entry("0412 345 678"), entry("+61400000002", name="Ben", active=False,
                                             expires_at="2027-01-01T00:00:00+00:00")],
    )  # fmt: skip
    assert (result.added, result.updated, result.removed, result.rejected) == (1, 1, 1, ())
    assert AuthorisedNumber.objects.get(number=ANA).role == "control"
    ben = AuthorisedNumber.objects.get(number="+61400000002")
    assert not ben.active and ben.expires_at.year == 2027
    gone = AuthorisedNumber.objects.get(number="+61400000001")
    assert list(gone.vessels.all()) == [vessel_a]  # kept for the other vessel and for the log


def test_an_unusable_entry_is_skipped_and_the_rest_applied(glider):
    result = authorised_numbers_replace(
        vessel=glider,
        numbers=[entry("not a number"), entry(ANA, role="admin"), entry("+61400000003"),
                 entry("+61400000004", expires_at="tomorrow")],
    )  # fmt: skip
    assert result.added == 1 and len(result.rejected) == 3
    assert list(AuthorisedNumber.objects.values_list("number", flat=True)) == ["+61400000003"]


def test_the_shore_says_who_receives_positions_and_an_older_shore_leaves_it(glider):
    authorised_numbers_replace(vessel=glider, numbers=[entry(ANA, receives_positions=True)])
    assert AuthorisedNumber.objects.get(number=ANA).receives_positions is True
    result = authorised_numbers_replace(vessel=glider, numbers=[entry(ANA)])  # no such field
    assert result.updated == 0 and AuthorisedNumber.objects.get(number=ANA).receives_positions
    authorised_numbers_replace(vessel=glider, numbers=[entry(ANA, receives_positions=False)])
    assert AuthorisedNumber.objects.get(number=ANA).receives_positions is False


def test_an_unchanged_list_writes_nothing(glider):
    authorised_numbers_replace(vessel=glider, numbers=[entry(ANA)])
    before = AuthorisedNumber.objects.get(number=ANA).updated_at
    result = authorised_numbers_replace(vessel=glider, numbers=[entry(ANA)])
    assert (result.added, result.updated, result.removed) == (0, 0, 0)
    assert AuthorisedNumber.objects.get(number=ANA).updated_at == before


@pytest.fixture
def offline_link(tmp_path, glider):
    config = ShoreConfig(url="http://127.0.0.1:9", key="k", outbox_path=str(tmp_path / "o.db"))
    link = ShoreLink(vessel=glider, config=config)
    yield link
    link.close()


def shore_command(glider, kind="fhead", **params):
    command = command_enqueue(vessel=glider, kind=kind, params=params or {"bearing": 90},
                              created_by=CREATED_BY)  # fmt: skip
    return command


def test_local_outcomes_become_acks_once_each(offline_link, glider):
    first = shore_command(glider, bearing=10)
    offline_link.outbox.command_claim(str(first.uid), "fhead")
    second = shore_command(glider, bearing=20)  # supersedes the first here
    offline_link.outbox.command_claim(str(second.uid), "fhead")
    command_cancel(command=second, actor="operator on the glider")
    assert offline_link.do_one_report_results() is True
    assert offline_link.do_one_report_results() is False  # nothing new
    acks = {i.body["uid"]: i.body for i in offline_link.outbox.peek("ack", 10)}
    # Superseded is an ack status on the shore too; cancelled is not, and goes up as failed.
    assert acks[str(first.uid)]["status"] == "superseded"
    assert acks[str(first.uid)]["detail"].startswith("superseded on the glider")
    assert acks[str(second.uid)]["status"] == "failed"
    assert acks[str(second.uid)]["detail"].startswith("cancelled on the glider")
    assert offline_link.outbox.commands_interrupted() == []


def test_a_shore_command_not_found_here_is_reported_lost(offline_link):
    offline_link.outbox.command_claim("6f1c2d3e-0000-4000-8000-000000000000", "fhead")
    offline_link.do_one_report_results()
    (ack,) = offline_link.outbox.peek("ack", 10)
    assert (ack.body["status"], ack.body["detail"]) == ("failed", "lost on the glider")


@pytest.mark.django_db(transaction=True)
def test_run_keeps_going_without_a_shore_and_stops_when_asked(tmp_path, glider):
    """Nothing listens at the URL: the thread logs, backs off, and ends at the stop flag."""
    config = ShoreConfig(url="http://127.0.0.1:9", key="k", outbox_path=str(tmp_path / "o.db"))
    link = ShoreLink(vessel=glider, config=config)
    stop = threading.Event()
    thread = threading.Thread(target=link.run, args=(stop,), kwargs={"idle_s": 0.05})
    thread.start()
    deadline = time.monotonic() + 10
    while link.state.reachable is None and time.monotonic() < deadline:
        time.sleep(0.02)
    stop.set()
    thread.join(10)
    assert not thread.is_alive()
    assert link.state.reachable is False and link.state.failures >= 1
    link.close()  # the bridge may close it again after run() did: harmless


class RecordingShore:
    """The transport boundary: records each upload and accepts it (the HTTP path is in
    test_shore.py against a live shore)."""

    def __init__(self, refuse: dict[str, int] | None = None) -> None:
        self.uploads: list[list[dict]] = []  # SMS log batches
        self.reports: list[list[dict]] = []  # command report batches
        self.calls: list[str] = []
        self.refuse = refuse or {}  # path → an HTTP status to answer it with

    def post_json(self, path: str, body: dict) -> Response:
        self.calls.append(path)
        if path in self.refuse:
            raise TransportError(f"HTTP {self.refuse[path]}", status=self.refuse[path])
        entries = body["commands"] if path == REPORT_PATH else body["messages"]
        (self.reports if path == REPORT_PATH else self.uploads).append(entries)
        answer = {"accepted": len(entries), "duplicates": 0, "rejected": []}
        return Response(200, {}, json.dumps(answer).encode())

    def get(self, path: str, etag: str | None = None) -> Response:
        return Response(304)  # nothing new down: the polls leave the link up

    def close(self) -> None:
        pass


def test_a_reply_held_for_the_cc_goes_up_only_once_it_has_its_send_status(tmp_path, glider):
    authorised_number_authorise(number=ANA, vessels=[glider], role="control", name="Ana")
    outcome = sms_handle_incoming(
        vessel=glider, number=ANA, text="#FHEAD 230", received_at=timezone.now(),
        reply_window_s=60,
    )  # fmt: skip
    (reply,) = outcome.replies
    assert reply.status == SendStatus.WAITING
    shore = RecordingShore()
    config = ShoreConfig(url="http://127.0.0.1:9", key="k", outbox_path=str(tmp_path / "o.db"))
    link = ShoreLink(vessel=glider, config=config, transport=shore)
    try:
        assert link.do_one_upload_sms() is True
        assert [m["direction"] for m in shore.uploads[-1]] == ["in"]  # the reply waits
        assert link.do_one_upload_sms() is False
        SmsMessage.objects.filter(pk=reply.pk).update(status=SendStatus.SENT)
        assert link.do_one_upload_sms() is True
        assert [(m["direction"], m["status"]) for m in shore.uploads[-1]] == [("out", "sent")]
    finally:
        link.close()


@pytest.fixture
def recording_link(tmp_path, glider):
    def make(shore: RecordingShore) -> ShoreLink:
        config = ShoreConfig(url="http://127.0.0.1:9", key="k", outbox_path=str(tmp_path / "o.db"))
        link = ShoreLink(vessel=glider, config=config, transport=shore)
        links.append(link)
        return link

    links: list[ShoreLink] = []
    yield make
    for link in links:
        link.close()


def test_the_gliders_own_commands_are_reported_at_each_change_and_shore_ones_never(
    recording_link, glider
):
    shore = RecordingShore()
    link = recording_link(shore)
    shore_command(glider, bearing=10)  # from the shore: its acks carry its state
    own = command_enqueue(vessel=glider, kind="fhead", params={"bearing": 230},
                          source="sms", created_by=ANA)  # fmt: skip
    assert link.do_one_report_commands() is True
    assert link.do_one_report_commands() is False  # nothing changed since
    ((sent,),) = shore.reports
    assert (sent["uid"], sent["status"], sent["created_by"]) == (str(own.uid), "queued", ANA)
    assert sent["params"] == {"bearing": 230} and sent["source"] == "sms"
    command_cancel(command=own, actor="operator on the glider")
    assert link.do_one_report_commands() is True
    assert [(c["uid"], c["status"]) for c in shore.reports[-1]] == [(str(own.uid), "cancelled")]


def test_the_command_report_goes_before_the_sms_log_that_names_it(recording_link, glider):
    authorised_number_authorise(number=ANA, vessels=[glider], role="control", name="Ana")
    sms_handle_incoming(vessel=glider, number=ANA, text="#FHEAD 230", received_at=timezone.now())
    shore = RecordingShore()
    link = recording_link(shore)
    assert link.do_one_upload_sms() is True  # the SMS step alone: it reports first
    assert shore.calls[:2] == [REPORT_PATH, SMS_PATH]
    sms_in = shore.uploads[0][0]  # (its reply waits for the modem)
    assert sms_in["commands"] == [shore.reports[0][0]["uid"]]


@pytest.mark.parametrize("refused", [404, 405, 400])
def test_a_report_the_shore_refuses_whole_is_kept_and_sent_once_it_is_taken(
    recording_link, glider, refused
):
    """A proxy's 404, a shore being upgraded, or a request it cannot read: no report is lost."""
    authorised_number_authorise(number=ANA, vessels=[glider], role="control", name="Ana")
    sms_handle_incoming(vessel=glider, number=ANA, text="#FHEAD 230", received_at=timezone.now())
    shore = RecordingShore(refuse={REPORT_PATH: refused})
    link = recording_link(shore)
    assert link.do_one() is False
    assert link.outbox.counter(REPORT_WATERMARK) == 0 and link.state.reachable is False
    assert link.state.down_until > 0  # backing off
    assert shore.uploads == []  # the SMS log waits behind the report that it names
    del shore.refuse[REPORT_PATH]  # the shore is back, with the endpoint
    assert link.do_one_upload_sms() is True
    (((reported),),) = shore.reports
    assert shore.uploads[0][0]["commands"] == [reported["uid"]]
    assert link.outbox.counter(REPORT_WATERMARK) > 0


def test_a_shore_that_is_down_gets_the_report_later(recording_link, glider):
    command_enqueue(vessel=glider, kind="fhead", params={"bearing": 5}, created_by=ANA)
    down = recording_link(RecordingShore(refuse={REPORT_PATH: 503}))
    assert down.do_one() is False
    assert down.state.reachable is False and down.outbox.counter(REPORT_WATERMARK) == 0


class ListingShore(RecordingShore):
    """A shore whose command poll lists ``open``: each answer a 200 with a new tag."""

    def __init__(self) -> None:
        super().__init__()
        self.open: list[dict] = []

    def get(self, path: str, etag: str | None = None) -> Response:
        tag = f'"{len(self.calls)}"'
        self.calls.append(path)
        return Response(200, {"etag": tag}, json.dumps({"commands": self.open}).encode())


def test_a_shore_command_dropped_there_is_withdrawn_here_unless_already_taken(tmp_path, glider):
    shore = ListingShore()
    config = ShoreConfig(url="http://127.0.0.1:9", key="k", outbox_path=str(tmp_path / "o.db"))
    link = ShoreLink(vessel=glider, config=config, transport=shore)
    waiting, taken = "6f1c2d3e-0000-4000-8000-000000000001", "6f1c2d3e-0000-4000-8000-000000000002"
    shore.open = [
        {"uid": waiting, "kind": "light", "params": {"state": "on"}},
        {"uid": taken, "kind": "light", "params": {"state": "off"}},
    ]
    try:
        assert link.do_one_poll_commands() is True
        mine = Command.objects.get(uid=taken)
        Command.objects.filter(pk=mine.pk).update(status="sent")  # the C&C took it meanwhile
        shore.open = []  # the operator cancelled both on the shore
        link.do_one_poll_commands()
        assert Command.objects.get(uid=waiting).status == "cancelled"  # never reaches the C&C
        assert Command.objects.get(uid=taken).status == "sent"  # on its way: it stays
    finally:
        link.close()
