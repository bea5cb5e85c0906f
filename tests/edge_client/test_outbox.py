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


def test_an_ack_detail_goes_as_text_the_shore_takes(outbox):
    """The shore refuses NUL and lone surrogates (a 400, after which the ack is dropped)."""
    outbox.add_ack("u1", "failed", "autopilot: no\x00 \ud800fix")
    (ack,) = outbox.peek("ack", 10)
    assert ack.body["detail"] == "autopilot: no\ufffd \ufffdfix"


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


# The writer stops itself in the middle of a transaction, at a chosen statement, once the box
# is full (so evictions run), says so, and waits there to be killed: the kill lands mid-write
# every time, not when a sleep happens to end. It reports the last fix it knows committed.
WRITER = """
import sys, threading
from edge_client.outbox import Outbox
box = Outbox(sys.argv[1], max_fixes=50, commit_every=int(sys.argv[2]))
stop_at = sys.argv[3]
committed = -1

def trace(sql):
    if " ".join(sql.split()).startswith(stop_at):
        print("stopped", committed, int(box._db.in_transaction), flush=True)
        threading.Event().wait()  # until SIGKILL

print("open", flush=True)
for n in range(10_000):
    if n == 60:
        box._db.set_trace_callback(trace)
    box.add_fix({"time": n, "lat": 1.0, "lon": 2.0, "readings": {"pad": "x" * 300}})
    if n % 7 == 0:
        box.add_ack(f"u{n}", "done", "y" * 200)
    if not box._pending:
        committed = n
print("never stopped", flush=True)
"""
FIX_INSERT = "INSERT INTO outbox (kind, body, created_at) VALUES ('fix'"


@pytest.mark.parametrize(
    ("stop_at", "commit_every"),
    [(FIX_INSERT, 1), ("DELETE FROM outbox", 1), ("COMMIT", 1), ("DELETE FROM outbox", 5)],
    ids=["insert", "evict", "commit", "evict-group"],
)
def test_killing_the_process_mid_write_corrupts_nothing(tmp_path, stop_at, commit_every):
    path = tmp_path / "o.sqlite3"
    proc = subprocess.Popen([sys.executable, "-c", WRITER, str(path), str(commit_every), stop_at],
                            stdout=subprocess.PIPE, cwd=os.getcwd())  # fmt: skip
    try:
        assert proc.stdout.readline() == b"open\n"
        word, committed, in_transaction = proc.stdout.readline().split()
        assert (word, in_transaction) == (b"stopped", b"1")  # killed inside a transaction
    finally:
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait()
    db = sqlite3.connect(path)
    assert db.execute("PRAGMA integrity_check").fetchone() == ("ok",)
    db.close()
    box = Outbox(path, max_fixes=50)
    fixes = box.peek("fix", 1000)
    assert len(fixes) == 50  # full, as it was when the kill came
    times = [f.body["time"] for f in fixes]
    assert times == list(range(times[0], times[0] + len(times)))  # contiguous, newest kept
    assert times[-1] == int(committed)  # every commit kept, nothing of the killed one
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


# -- group commits ---------------------------------------------------------------------------


def on_disk(path) -> dict[str, int]:
    """What another process (or the box after a power cut) would find: committed rows only."""
    db = sqlite3.connect(f"file:{path}?mode=ro", uri=True)
    try:
        return dict(db.execute("SELECT kind, COUNT(*) FROM outbox GROUP BY kind").fetchall())
    finally:
        db.close()


def test_fixes_are_committed_in_groups_and_before_they_are_read_to_be_sent(tmp_path):
    path = tmp_path / "o.sqlite3"
    box = Outbox(path, commit_every=5)
    for n in range(4):
        box.add_fix(fix(n))
    assert on_disk(path) == {} and box.count("fix") == 4 == box.count()
    box.add_fix(fix(4))
    assert on_disk(path) == {"fix": 5}
    box.add_fix(fix(5))
    box.add_fix(fix(6))
    assert on_disk(path) == {"fix": 5}
    assert [i.body["time"] - 1_700_000_000 for i in box.peek("fix", 10)] == list(range(7))
    assert on_disk(path) == {"fix": 7}  # nothing is sent before it is on disk
    assert box.counter("recorded_fixes") == 7
    box.close()


def test_an_ack_or_a_command_claim_takes_the_waiting_fixes_along(tmp_path):
    path = tmp_path / "o.sqlite3"
    box = Outbox(path, commit_every=100)
    box.add_fix(fix(1))
    box.add_ack("u1", "acknowledged")
    assert on_disk(path) == {"fix": 1, "ack": 1}
    box.add_fix(fix(2))
    box.command_claim("u2", "hold")
    assert on_disk(path) == {"fix": 2, "ack": 1}
    box.close()


def test_a_clean_close_commits_the_waiting_fixes(tmp_path):
    path = tmp_path / "o.sqlite3"
    box = Outbox(path, commit_every=100)
    for n in range(3):
        box.add_fix(fix(n))
    box.close()
    reopened = Outbox(path)
    assert [i.body for i in reopened.peek("fix", 10)] == [fix(0), fix(1), fix(2)]
    assert reopened.counter("recorded_fixes") == 3
    reopened.close()


def test_grouped_fixes_are_still_bounded_and_evictions_counted(tmp_path):
    box = Outbox(tmp_path / "o.sqlite3", max_fixes=10, commit_every=4)
    for n in range(25):
        box.add_fix(fix(n))
    assert [i.body["time"] - 1_700_000_000 for i in box.peek("fix", 100)] == list(range(15, 25))
    assert box.counter("evicted_fixes") == 15
    box.close()


def synced_transactions(box: Outbox) -> list[tuple[str, str]]:
    """Trace the box's connection: (synchronous level at COMMIT, the first statement's first
    three words) for each transaction committed."""
    level, first, seen = box._synchronous, None, []

    def trace(sql: str) -> None:
        nonlocal level, first
        sql = " ".join(sql.split())
        if sql.startswith("PRAGMA synchronous="):
            level = sql.split("=")[1]
        elif sql.startswith("BEGIN"):
            first = None
        elif sql == "COMMIT":
            seen.append((level, first))
        elif first is None:
            first = " ".join(sql.split()[:3])

    box._db.set_trace_callback(trace)
    return seen


def test_what_carries_a_promise_is_fsynced_and_the_rest_is_not(tmp_path):
    """synchronous=FULL (an fsync of the WAL) for fixes, acks and command records; NORMAL
    (no fsync; a power cut may undo it, and the fix is only sent again) for the rest."""
    box = Outbox(tmp_path / "o.sqlite3", commit_every=3)
    seen = synced_transactions(box)
    for n in range(3):
        box.add_fix(fix(n))
    box.add_ack("u1", "done")
    box.command_claim("u1", "hold")
    box.command_finish("u1")
    box.remove([i.id for i in box.peek("fix", 10)])
    box.bump("rejected_fixes")
    assert seen == [
        ("FULL", "INSERT INTO outbox"),
        ("FULL", "INSERT INTO outbox"),
        ("FULL", "INSERT OR IGNORE"),
        ("FULL", "UPDATE commands SET"),
        ("NORMAL", "DELETE FROM outbox"),
        ("NORMAL", "INSERT INTO counters"),
    ]
    assert box._db.execute("PRAGMA synchronous").fetchone() == (1,)  # NORMAL between them
    box.close()


def test_fixes_waiting_on_a_failing_disk_stay_bounded_and_are_counted(tmp_path, monkeypatch):
    box = Outbox(tmp_path / "o.sqlite3", max_fixes=5, commit_every=1)
    real_write = Outbox._write_pending

    def failing_disk(self, db):
        raise sqlite3.OperationalError("disk I/O error")

    monkeypatch.setattr(Outbox, "_write_pending", failing_disk)
    for i in range(20):
        with pytest.raises(sqlite3.OperationalError):
            box.add_fix({"n": i})
    assert box.count("fix") == 5  # held in memory, no more than the disk would hold

    monkeypatch.setattr(Outbox, "_write_pending", real_write)
    box.commit()
    assert [item.body["n"] for item in box.peek("fix", 10)] == [15, 16, 17, 18, 19]
    assert box.counter("evicted_fixes") == 15
    assert box.counter("recorded_fixes") == 20
