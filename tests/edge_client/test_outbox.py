from __future__ import annotations

import os
import signal
import sqlite3
import subprocess
import sys
import time

import pytest

from edge_client.outbox import Outbox, settle_fix_batch


def fix(n: int) -> dict:
    return {"time": 1_700_000_000 + n, "lat": -31.9 + n * 1e-5, "lon": 115.8}


def test_fixes_leave_oldest_first(outbox):
    for n in range(5):
        outbox.add_fix(fix(n))
    items = outbox.peek("fix", 3)
    assert [i.body["time"] for i in items] == [1_700_000_000, 1_700_000_001, 1_700_000_002]
    outbox.remove([i.id for i in items])
    assert [i.body["time"] for i in outbox.peek("fix", 10)] == [1_700_000_003, 1_700_000_004]


def test_acks_and_fixes_are_queued_separately(outbox):
    outbox.add_fix(fix(0))
    outbox.add_ack("u1", "acknowledged", "ok")
    outbox.add_ack("u1", "done", "arrived")
    assert [(a.body["uid"], a.body["status"]) for a in outbox.peek("ack", 10)] == [
        ("u1", "acknowledged"),
        ("u1", "done"),
    ]
    assert outbox.count("fix") == 1 and outbox.count() == 3


def test_a_full_outbox_evicts_the_oldest_fixes_and_counts_them(tmp_path):
    box = Outbox(tmp_path / "o.sqlite3", max_fixes=10)
    box.add_ack("u1", "done")
    for n in range(25):
        box.add_fix(fix(n))
    assert box.count("fix") == 10
    assert [i.body["time"] - 1_700_000_000 for i in box.peek("fix", 100)] == list(range(15, 25))
    assert box.counter("evicted_fixes") == 15
    assert box.count("ack") == 1  # acks are never evicted
    box.close()
    reopened = Outbox(tmp_path / "o.sqlite3", max_fixes=10)
    assert reopened.counter("evicted_fixes") == 15  # survives a restart
    reopened.close()


def test_everything_survives_a_reopen(tmp_path):
    box = Outbox(tmp_path / "o.sqlite3")
    box.add_fix(fix(1))
    box.add_ack("u9", "failed", "no GPS")
    box.close()
    box = Outbox(tmp_path / "o.sqlite3")
    assert [i.body for i in box.peek("fix", 5)] == [fix(1)]
    assert box.peek("ack", 5)[0].body == {"uid": "u9", "status": "failed", "detail": "no GPS"}
    box.close()


def test_nan_never_gets_in(outbox):
    with pytest.raises(ValueError):
        outbox.add_fix({"time": 1, "lat": float("nan"), "lon": 0})
    assert outbox.count() == 0


def test_command_uids_are_claimed_once_across_restarts(tmp_path):
    box = Outbox(tmp_path / "o.sqlite3")
    assert box.command_claim("u1", "move_to") is True
    assert box.command_claim("u1", "move_to") is False
    box.command_finish("u1")
    assert box.command_claim("u2", "hold") is True
    box.close()
    box = Outbox(tmp_path / "o.sqlite3")
    assert box.command_claim("u1", "move_to") is False
    assert box.commands_interrupted() == [("u2", "hold")]
    box.close()


def test_old_finished_commands_are_forgotten(outbox):
    outbox.command_claim("old", "hold")
    outbox.command_finish("old")
    outbox.command_claim("running", "move_to")
    outbox.commands_forget_old(now=time.time() + 40 * 24 * 3600)
    assert outbox.command_claim("old", "hold") is True
    assert outbox.command_claim("running", "move_to") is False


WRITER = """
import sys
from edge_client.outbox import Outbox
box = Outbox(sys.argv[1], max_fixes=200)
print("open", flush=True)
n = 0
while True:
    box.add_fix({"time": n, "lat": 1.0, "lon": 2.0, "readings": {"pad": "x" * 300}})
    if n % 7 == 0:
        box.add_ack(f"u{n}", "done", "y" * 200)
    n += 1
"""


@pytest.mark.parametrize("delay", [0.05, 0.2, 0.5])
def test_killing_the_process_mid_write_corrupts_nothing(tmp_path, delay):
    path = tmp_path / "o.sqlite3"
    proc = subprocess.Popen([sys.executable, "-c", WRITER, str(path)], stdout=subprocess.PIPE,
                            cwd=os.getcwd())  # fmt: skip
    assert proc.stdout.readline() == b"open\n"
    time.sleep(delay)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    db = sqlite3.connect(path)
    assert db.execute("PRAGMA integrity_check").fetchone() == ("ok",)
    db.close()
    box = Outbox(path, max_fixes=200)
    fixes = box.peek("fix", 1000)
    assert 0 < len(fixes) <= 200
    times = [f.body["time"] for f in fixes]
    assert times == list(range(times[0], times[0] + len(times)))  # contiguous, newest kept
    assert box.counter("evicted_fixes") == times[0]  # every eviction was counted
    box.add_fix(fix(1))  # and it is still writable
    box.close()


def test_settle_accepts_and_duplicates_leave():
    s = settle_fix_batch([11, 12, 13], {"accepted": 2, "duplicates": 1, "rejected": []})
    assert s.remove == (11, 12, 13) and not s.rejected and not s.keep_reason


def test_settle_drops_rejected_fixes_with_their_errors():
    answer = {"accepted": 1, "duplicates": 0, "rejected": [{"index": 1, "errors": {"lat": "x"}}]}
    s = settle_fix_batch([11, 12], answer)
    assert s.remove == (11, 12)
    assert s.rejected == ((12, {"lat": "x"}),)


@pytest.mark.parametrize(
    "answer",
    [
        None,
        [],
        {"accepted": 1},
        {"accepted": 1, "duplicates": 0, "rejected": []},  # one of two unaccounted for
        {"accepted": 1, "duplicates": 0, "rejected": [{"index": 5}]},
        {"accepted": "2", "duplicates": 0},
    ],
)
def test_settle_keeps_everything_when_the_answer_does_not_add_up(answer):
    s = settle_fix_batch([11, 12], answer)
    assert s.remove == () and s.keep_reason
