"""The glider's shore link against a live shore: a real Shoreside process (gunicorn) with a
database of its own, reached over HTTP through a TCP relay that can be cut (an outage).

Two databases, as in the field: the glider side (:class:`ShoreLink`, the SMS services, the
command source) runs in this process on the test database; the shore is another process on
its own SQLite file, set up and read through its own ``manage.py``. Two databases are needed,
not just two vessel rows: the glider queues a shore command under the shore's uid, and a uid is
unique in one database.
"""

from __future__ import annotations

import datetime as dt
import os
import shutil
import socket
import sqlite3
import subprocess
import sys
import threading
import time
import urllib.request
from pathlib import Path

import pytest
from django.db import connections
from django.utils import timezone

from commands.models import Command
from sms.bridge.commands import DatabaseCommandSource
from sms.bridge.dispatch import Dispatcher
from sms.bridge.fixes import FixRecorder
from sms.bridge.machine import BridgeMachine
from sms.bridge.shore import (
    CREATED_BY,
    FIX_WATERMARK,
    REPORT_WATERMARK,
    SMS_WATERMARK,
    ShoreConfig,
    ShoreLink,
)
from sms.level2.payload import PayloadConfig
from sms.level2.runner import PayloadRunner, PtyPort, SerialLink
from sms.level2.simulator import CcSimulator, SimConfig, VirtualClock
from sms.services import sms_handle_incoming, sms_mark_sent, sms_outgoing_pending
from telemetry.models import Fix
from telemetry.services import fix_ingest
from tests.edge_client.conftest import free_port
from tests.edge_client.helpers import ROOT, TcpProxy, start, stop, wait_until

pytestmark = [pytest.mark.slow, pytest.mark.django_db]

ANA = "+61412345678"
BEN = "+61412345679"
T0 = dt.datetime(2026, 11, 25, 6, 0, tzinfo=dt.UTC)


def _env(db: Path) -> dict[str, str]:
    env = {**os.environ, "DATABASE_URL": f"sqlite:///{db}", "PYTHONPATH": str(ROOT)}
    env.pop("NOTIFY_SOCKET", None)
    return env


class Shore:
    """A Shoreside process with its own database; ``url`` goes through a relay that
    :meth:`down` cuts and :meth:`up` restores."""

    def __init__(self, tmp: Path, template: Path) -> None:
        self.db = tmp / "shore.sqlite3"
        shutil.copy(template, self.db)
        self.port = free_port(socket.SOCK_STREAM)
        self.proc = self._start(tmp)
        self.proxy = TcpProxy(("127.0.0.1", self.port))
        self.url = f"http://127.0.0.1:{self.proxy.port}"
        wait_until(self._answers, 30, "the shore server to start")

    def _start(self, tmp: Path) -> subprocess.Popen:
        saved = os.environ.get("DATABASE_URL")
        os.environ["DATABASE_URL"] = f"sqlite:///{self.db}"
        try:
            return start(
                ["-m", "gunicorn", "fleet.wsgi:application", "-b", f"127.0.0.1:{self.port}",
                 "-w", "1", "--threads", "2"],
                tmp / "shore.log",
            )  # fmt: skip
        finally:
            if saved is None:
                os.environ.pop("DATABASE_URL")
            else:
                os.environ["DATABASE_URL"] = saved

    def _answers(self) -> bool:
        try:
            urllib.request.urlopen(f"http://127.0.0.1:{self.port}/api/v1/boat/commands/", timeout=1)
        except urllib.error.HTTPError:
            return True  # 401: up
        except OSError:
            return False
        return True

    def manage(self, *args: str) -> str:
        done = subprocess.run(
            [sys.executable, "manage.py", *args],
            cwd=ROOT,
            env=_env(self.db),
            capture_output=True,
            text=True,
            check=True,
        )
        return done.stdout.strip()

    def django(self, code: str) -> str:
        """Run ``code`` in the shore's ``manage.py shell``; its last line of output."""
        return self.manage("shell", "-c", code).splitlines()[-1]

    def sql(self, query: str, *args: object) -> list[tuple]:
        db = sqlite3.connect(f"file:{self.db}?mode=ro", uri=True)
        try:
            return db.execute(query, args).fetchall()
        finally:
            db.close()

    def down(self) -> None:
        self.proxy.down()

    def up(self) -> None:
        self.proxy.up()

    def close(self) -> None:
        self.proxy.down()
        stop(self.proc)


@pytest.fixture(scope="module")
def shore_template(tmp_path_factory) -> Path:
    db = tmp_path_factory.mktemp("shore-template") / "shore.sqlite3"
    subprocess.run(
        [sys.executable, "manage.py", "migrate", "-v0"], cwd=ROOT, env=_env(db), check=True
    )
    return db


@pytest.fixture
def shore(tmp_path, shore_template):
    server = Shore(tmp_path, shore_template)
    yield server
    server.close()


@pytest.fixture
def link(tmp_path, shore, glider):
    """The shore's record of the glider (its own vessel and key there) and the glider's link."""
    key = shore.django(
        "from vessels.services import vessel_create, vessel_key_issue\n"
        "v = vessel_create(slug='glider', name='Wave Glider', kind='wave_glider')\n"
        "print(vessel_key_issue(vessel=v, label='glider')[1])"
    )
    config = ShoreConfig(
        url=shore.url, key=key, outbox_path=str(tmp_path / "outbox.sqlite3"), timeout_s=5
    )
    shore_link = ShoreLink(vessel=glider, config=config)
    yield shore_link
    shore_link.close()


def settle(link: ShoreLink) -> None:
    """Run the link's steps until none has anything left to do."""
    link.kick()
    for _ in range(50):
        if not link.do_one():
            return
    raise AssertionError("the link never settled")


def record_fixes(glider, start: int, count: int) -> None:
    records = [
        {"time": (T0 + dt.timedelta(seconds=i)).isoformat(), "lat": -31.98,
         "lon": 115.82 + i * 1e-4, "readings": {"water_temp_c": 20.0 + i}}
        for i in range(start, start + count)
    ]  # fmt: skip
    assert fix_ingest(vessel=glider, records=records).accepted == count


def shore_fix_times(shore: Shore) -> list[str]:
    return [row[0] for row in shore.sql("SELECT recorded_at FROM telemetry_fix ORDER BY 1")]


def test_fixes_arrive_exactly_once_after_an_outage(shore, link, glider):
    record_fixes(glider, 0, 3)
    shore.down()
    settle(link)  # no exception: logged, backed off
    assert link.state.reachable is False and shore_fix_times(shore) == []
    record_fixes(glider, 3, 2)
    shore.up()
    settle(link)
    assert link.state.reachable is True
    assert len(shore_fix_times(shore)) == 5
    # A crash before the watermark was saved: everything goes again, the shore dedupes.
    link.outbox.bump(FIX_WATERMARK, -link.outbox.counter(FIX_WATERMARK))
    settle(link)
    times = shore_fix_times(shore)
    assert len(times) == len(set(times)) == 5
    readings = shore.sql("SELECT readings FROM telemetry_fix ORDER BY recorded_at LIMIT 1")
    assert "water_temp_c" in readings[0][0]


def test_a_shore_command_is_queued_here_once_and_ends_done_on_the_shore(shore, link, glider):
    uid = shore.django(
        "from commands.services import command_enqueue\n"
        "from vessels.models import Vessel\n"
        "c = command_enqueue(vessel=Vessel.objects.get(slug='glider'), kind='fhead',"
        " params={'bearing': 230}, created_by='operator')\n"
        "print(c.uid)"
    )
    settle(link)
    settle(link)  # a second poll offers nothing new (and a re-offer would not duplicate it)
    local = Command.objects.get(uid=uid)
    assert (local.vessel, local.kind, local.params) == (glider, "fhead", {"bearing": 230})
    assert (local.status, local.created_by) == ("queued", CREATED_BY)
    assert Command.objects.filter(vessel=glider).count() == 1
    # The Level 2 side: the C&C takes it (handover) and ACKs it.
    source = DatabaseCommandSource(vessel=glider)
    assert source.take_next().ident == uid
    settle(link)
    shore_status = "SELECT status, result_detail FROM commands_command WHERE uid = ?"
    assert shore.sql(shore_status, uid.replace("-", ""))[0][0] == "acknowledged"
    source.result_without_command(0)
    settle(link)
    assert shore.sql(shore_status, uid.replace("-", ""))[0] == ("done", "C&C: ACK (accepted)")


def test_a_nak_from_the_cc_fails_the_command_on_the_shore(shore, link, glider):
    uid = shore.django(
        "from commands.services import command_enqueue\n"
        "from vessels.models import Vessel\n"
        "c = command_enqueue(vessel=Vessel.objects.get(slug='glider'), kind='fhead',"
        " params={'bearing': 10})\n"
        "print(c.uid)"
    )
    settle(link)
    source = DatabaseCommandSource(vessel=glider)
    source.take_next()
    source.result_without_command(2)  # NAK: invalid data
    settle(link)
    rows = shore.sql("SELECT status, result_detail FROM commands_command WHERE uid = ?",
                     uid.replace("-", ""))  # fmt: skip
    assert rows[0][0] == "failed" and "invalid data" in rows[0][1]


def answered(glider, number: str, text: str = "#STATUS") -> bool:
    outcome = sms_handle_incoming(
        vessel=glider, number=number, text=text, received_at=timezone.now()
    )
    return bool(outcome.replies)


def test_numbers_changed_on_the_shore_are_obeyed_after_the_next_sync(shore, link, glider):
    shore.manage("authorise_number", ANA, "--vessel", "glider", "--role", "control",
                 "--name", "Ana")  # fmt: skip
    assert not answered(glider, ANA)  # not known here yet
    settle(link)
    assert answered(glider, ANA)
    shore.django(  # one shell for both changes: each manage.py start costs seconds
        "from sms.services import authorised_number_authorise as add,"
        " authorised_number_deauthorise as remove\n"
        "from vessels.models import Vessel\n"
        f"add(number='{BEN}', vessels=[Vessel.objects.get(slug='glider')], role='query',"
        " name='Ben')\n"
        f"print(remove(number='{ANA}'))"
    )
    settle(link)
    assert not answered(glider, ANA)
    assert answered(glider, BEN)
    assert not answered(glider, BEN, "#FHEAD 90")  # a query role may not command


def test_the_glider_answers_sms_while_the_shore_is_down(shore, link, glider):
    shore.manage("authorise_number", ANA, "--vessel", "glider", "--role", "control",
                 "--name", "Ana")  # fmt: skip
    settle(link)
    shore.down()
    settle(link)  # the sync fails: the last list stays
    assert link.state.reachable is False
    assert answered(glider, ANA, "#FHEAD 230")
    assert Command.objects.filter(vessel=glider, kind="fhead", status="queued").exists()


def test_the_sms_log_arrives_once(shore, link, glider):
    shore.manage("authorise_number", ANA, "--vessel", "glider", "--role", "control",
                 "--name", "Ana")  # fmt: skip
    settle(link)
    sms_handle_incoming(vessel=glider, number=ANA, text="#FHEAD 230", received_at=T0)
    sms_handle_incoming(vessel=glider, number="+61400000000", text="hello", received_at=T0)
    settle(link)
    uploaded = "SELECT direction, text, status FROM sms_smsmessage ORDER BY created_at, id"
    # The reply waits for the modem's answer before it goes up.
    assert [row[0] for row in shore.sql(uploaded)] == ["in"]
    (reply,) = sms_outgoing_pending(vessel=glider)
    sms_mark_sent(message=reply, reference=7, now=timezone.now())
    settle(link)
    link.outbox.bump(SMS_WATERMARK, -link.outbox.counter(SMS_WATERMARK))  # a lost watermark
    settle(link)
    rows = shore.sql(uploaded)
    assert [(r[0], r[2]) for r in rows] == [("in", ""), ("out", "sent"), ("in", "")]
    assert rows[1][1] == "#FHEAD 230 QUEUED"
    # The command the SMS made went up first (reported), so the shore links it to the SMS.
    linked = shore.sql(
        "SELECT m.direction, c.kind, c.reported FROM sms_smsmessage_commands l"
        " JOIN sms_smsmessage m ON m.id = l.smsmessage_id"
        " JOIN commands_command c ON c.id = l.command_id ORDER BY m.direction"
    )
    assert linked == [("in", "fhead", 1), ("out", "fhead", 1)]  # the SMS and its reply


SHORE_COMMAND = "SELECT status, result_detail, reported, source, created_by FROM commands_command"


def test_a_command_texted_to_the_glider_reaches_the_shore_with_its_result_and_its_sms(
    shore, link, glider
):
    """Issue 11: "an operator on the shore sees the same command, its SMS and its result"."""
    shore.manage("authorise_number", ANA, "--vessel", "glider", "--role", "control",
                 "--name", "Ana")  # fmt: skip
    settle(link)
    sms_handle_incoming(vessel=glider, number=ANA, text="#FHEAD 230", received_at=T0)
    settle(link)
    (local,) = Command.objects.filter(vessel=glider)
    uid = local.uid.hex
    assert shore.sql(f"{SHORE_COMMAND} WHERE uid = ?", uid) == [
        ("queued", "", 1, "sms", f"vessel:glider/{ANA}")
    ]
    # The C&C takes it and ACKs (the Level 2 side, as in the tests above).
    source = DatabaseCommandSource(vessel=glider)
    assert source.take_next().ident == str(local.uid)
    source.result_without_command(0)
    settle(link)
    assert shore.sql(f"{SHORE_COMMAND} WHERE uid = ?", uid) == [
        ("done", "C&C: ACK (accepted)", 1, "sms", f"vessel:glider/{ANA}")
    ]
    events = shore.sql(
        "SELECT e.to_status, e.actor FROM commands_commandevent e JOIN commands_command c"
        " ON c.id = e.command_id WHERE c.uid = ? ORDER BY e.id", uid
    )  # fmt: skip
    assert events == [(s, "vessel") for s in ("queued", "sent", "acknowledged", "done")]
    sms = shore.sql(
        "SELECT m.text FROM sms_smsmessage m JOIN sms_smsmessage_commands l"
        " ON l.smsmessage_id = m.id JOIN commands_command c ON c.id = l.command_id"
        " WHERE c.uid = ?", uid
    )  # fmt: skip
    assert sms == [("#FHEAD 230",)]
    # The shore never offered the mirrored command back down: nothing was queued twice here
    # and nothing is waiting for an ack there.
    assert Command.objects.filter(vessel=glider).count() == 1
    assert link.outbox.commands_interrupted() == []
    # A lost watermark re-sends every report: duplicates on the shore, nothing changes.
    link.outbox.bump(REPORT_WATERMARK, -link.outbox.counter(REPORT_WATERMARK))
    settle(link)
    assert shore.sql("SELECT COUNT(*) FROM commands_commandevent") == [(4,)]


def test_no_failure_reaches_the_caller_when_the_shore_never_answered(tmp_path, glider):
    config = ShoreConfig(
        url=f"http://127.0.0.1:{free_port(socket.SOCK_STREAM)}", key="nope",
        outbox_path=str(tmp_path / "o.sqlite3"), timeout_s=1,
    )  # fmt: skip
    shore_link = ShoreLink(vessel=glider, config=config)
    record_fixes(glider, 0, 1)
    started = time.monotonic()
    assert shore_link.do_one() is False
    assert shore_link.state.reachable is False and shore_link.state.down_until > started
    assert shore_link.do_one() is False  # backing off: nothing tried
    shore_link.close()


@pytest.mark.django_db(transaction=True)
def test_a_shore_command_reaches_the_cc_through_a_pty_and_ends_done_on_the_shore(
    shore, link, glider
):
    """The whole way: shore → link → local queue → Level 2 (C&C simulator on a pty) → ACK →
    ack to the shore; the C&C's positions go up as the glider's fixes."""
    uid = shore.django(
        "from commands.services import command_enqueue\n"
        "from vessels.models import Vessel\n"
        "c = command_enqueue(vessel=Vessel.objects.get(slug='glider'), kind='fhead',"
        " params={'bearing': 230})\n"
        "print(c.uid)"
    )
    settle(link)
    pty = PtyPort(timeout=0.01)
    source = DatabaseCommandSource(vessel=glider)
    machine = BridgeMachine(PayloadConfig(poll_period_s=1), source=source)
    fixes = FixRecorder(vessel=glider, batch_size=1)
    dispatch = Dispatcher(machine=machine, source=source, fixes=fixes)
    runner = PayloadRunner(pty.name, machine, reconnect_delay_s=0.05, on_notification=dispatch)

    def serve() -> None:
        try:
            runner.run()
        finally:
            connections.close_all()  # this thread's own connection

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    try:
        assert runner.connected.wait(5)
        config = SimConfig(period_s=1.0, reply_wait_s=2.0, silence_wait_s=0.02)
        sim = CcSimulator(SerialLink(pty), config, VirtualClock())
        assert sim.enumerate()
        for _ in range(4):
            sim.clock.sleep(1.0)
            sim.poll_once()
        (packet,) = sim.stats.commands
        assert int.from_bytes(packet.params[3:5], "little") == 230
        local = Command.objects.get(uid=uid)
        wait_until(lambda: local.refresh_from_db() or local.status == "done", 10, "the ACK")
        fixes.flush()
    finally:
        runner.stop()
        thread.join(5)
        pty.close()
    settle(link)
    rows = shore.sql("SELECT status, result_detail FROM commands_command WHERE uid = ?",
                     uid.replace("-", ""))  # fmt: skip
    assert rows == [("done", "C&C: ACK (accepted)")]
    local_fixes = Fix.objects.filter(vessel=glider).count()
    assert local_fixes > 0 and len(shore_fix_times(shore)) == local_fixes
