"""Store-and-forward outbox on disk (sqlite3 from the standard library).

Every fix and every command ack is written here *before* any attempt to send it, and leaves only
when the server has answered for it (docs/edge-client.md). This module is responsible for:

- Order: items go out oldest first (``id`` is an AUTOINCREMENT rowid, never reused).
- Bounded: at most ``max_fixes`` fixes; adding one more evicts the oldest, and the number evicted
  is kept in the ``counters`` table (it survives restarts and is logged and reported).
  Acks are never evicted: losing one would leave a command re-offered forever, and there are
  only ever a handful.
- Durability with few writes (an SD card wears, and each fsync costs tens of ms there): fixes
  are committed in groups. :meth:`Outbox.add_fix` keeps a fix in memory; the fix is *accepted*
  (it survives a power cut) once its group is committed, which happens

  * when ``commit_every`` fixes are waiting,
  * before fixes are read to be sent (:meth:`peek`), so nothing leaves before it is on disk:
    with the client's uplink that is once per poll period,
  * with any ack or command claim/finish (those are committed at once: a command must be on
    disk before it runs), and at :meth:`close` (a clean stop).

  A power cut (or a crash) loses at most the fixes not yet committed: fewer than
  ``commit_every``, sampled since the last uplink round. ``commit_every=1`` commits each fix.
- Crash safety: WAL journal. Group commits, acks and command records are committed with
  ``synchronous=FULL`` (the WAL is fsynced, which also makes every earlier commit durable);
  everything else (fixes leaving after the server's answer, counters) runs with
  ``synchronous=NORMAL``: no fsync, and a power cut may undo it, which only means a fix is
  sent again (the server counts it a duplicate). Every change is one transaction, so a
  process killed mid-write leaves the previous committed state (tested by SIGKILL mid-insert).
- Command dedupe: the ``commands`` table remembers every command uid the executor has started,
  so a command re-offered after a restart is not run again (the original SPAB client re-ran a
  ``moveTo`` on every poll).

The pure decision "which outbox rows may leave after this server answer" is
:func:`settle_fix_batch`; this module's class only does storage.
"""

from __future__ import annotations

import json
import logging
import re
import sqlite3
import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

log = logging.getLogger(__name__)

SCHEMA = """
CREATE TABLE IF NOT EXISTS outbox (
    id INTEGER PRIMARY KEY AUTOINCREMENT,
    kind TEXT NOT NULL CHECK (kind IN ('fix', 'ack')),
    body TEXT NOT NULL,
    created_at REAL NOT NULL
);
CREATE INDEX IF NOT EXISTS outbox_kind_id ON outbox (kind, id);
CREATE TABLE IF NOT EXISTS counters (name TEXT PRIMARY KEY, value INTEGER NOT NULL);
CREATE TABLE IF NOT EXISTS commands (
    uid TEXT PRIMARY KEY,
    kind TEXT NOT NULL,
    state TEXT NOT NULL CHECK (state IN ('running', 'finished')),
    updated_at REAL NOT NULL
);
"""

UNSENDABLE = re.compile("[\x00\ud800-\udfff]")
EVICTION_LOG_EVERY_S = 600.0
# Remember finished command uids this long; the server stops offering a command once acked.
COMMAND_MEMORY_S = 30 * 24 * 3600


@dataclass(frozen=True)
class Item:
    id: int
    kind: str
    body: dict[str, Any]


@dataclass(frozen=True)
class Settlement:
    """What to do with a batch of fixes after the server's answer."""

    remove: tuple[int, ...]
    rejected: tuple[tuple[int, Any], ...]  # (outbox id, server's errors) — logged and dropped
    keep_reason: str = ""


def settle_fix_batch(ids: Sequence[int], answer: Any) -> Settlement:
    """Decide which fixes of a batch leave the outbox after a 200 from ``POST boat/telemetry/``.

    The answer is the contract's batch answer (``edge_client.contract.batch``, docs/api.md):
    ``{"accepted": n, "duplicates": n, "rejected": [{"index": i, "errors": ...}]}``. Accepted
    and duplicate fixes are on the server; a rejected one never will be, so it is dropped too
    (after logging). If the answer does not account for every fix in the
    batch, nothing leaves: re-sending is harmless (the server dedupes on vessel + time), losing
    a fix is not.
    """
    if not isinstance(answer, dict):
        return Settlement((), (), "answer is not a JSON object")
    accepted, duplicates = answer.get("accepted"), answer.get("duplicates")
    rejected = answer.get("rejected", [])
    if not isinstance(accepted, int) or not isinstance(duplicates, int):
        return Settlement((), (), "answer lacks accepted/duplicates counts")
    if not isinstance(rejected, list):
        return Settlement((), (), "answer's rejected is not a list")
    bad: list[tuple[int, Any]] = []
    for entry in rejected:
        index = entry.get("index") if isinstance(entry, dict) else None
        if not isinstance(index, int) or not 0 <= index < len(ids):
            return Settlement((), (), f"answer rejects an unknown index {index!r}")
        bad.append((ids[index], entry.get("errors")))
    if accepted + duplicates + len(bad) != len(ids):
        return Settlement(
            (),
            (),
            f"answer accounts for {accepted + duplicates + len(bad)} of {len(ids)} fixes",
        )
    return Settlement(tuple(ids), tuple(bad))


class Outbox:
    """The on-disk queue. Thread-safe: one connection guarded by a lock.

    ``synchronous`` is the level of the commits that promise nothing ("NORMAL"); "FULL" makes
    every commit fsync, as before group commits (with ``commit_every=1``: the old behaviour,
    the benchmark's baseline).
    """

    def __init__(
        self,
        path: str | Path,
        *,
        max_fixes: int = 100_000,
        commit_every: int = 1,
        synchronous: str = "NORMAL",
    ) -> None:
        if synchronous not in ("NORMAL", "FULL"):
            raise ValueError(f"synchronous must be NORMAL or FULL, not {synchronous!r}")
        self.path = str(path)
        self.max_fixes = max_fixes
        self.commit_every = max(1, commit_every)
        self._synchronous = synchronous
        if self.path != ":memory:":
            Path(self.path).parent.mkdir(parents=True, exist_ok=True)
        self._lock = threading.Lock()
        self._eviction_logged = -EVICTION_LOG_EVERY_S
        self._pending: list[tuple[str, float]] = []  # fixes not committed yet: (body, created_at)
        self._pending_evicted = 0  # waiting fixes dropped while commits failed (see add_fix)
        # isolation_level=None: we issue BEGIN/COMMIT ourselves so each change is one transaction.
        self._db = sqlite3.connect(self.path, isolation_level=None, check_same_thread=False)
        self._db.execute("PRAGMA journal_mode=WAL")
        self._db.execute(f"PRAGMA synchronous={synchronous}")
        self._db.execute("PRAGMA busy_timeout=5000")
        for statement in SCHEMA.strip().split(";"):
            if statement.strip():
                self._db.execute(statement)

    def close(self) -> None:
        """Commit the fixes still waiting (a clean stop loses none), then close."""
        try:
            self.commit()
        finally:
            with self._lock:
                self._db.close()

    # -- transactions -------------------------------------------------------------------------

    class _Tx:
        def __init__(self, outbox: Outbox, durable: bool) -> None:
            self.outbox = outbox
            self.durable = durable

        def __enter__(self) -> sqlite3.Connection:
            self.outbox._lock.acquire()
            db = self.outbox._db
            try:
                if self.durable:
                    # Takes effect at this transaction's COMMIT: the WAL is fsynced, which makes
                    # the earlier NORMAL commits durable too (they sit before it in the WAL).
                    db.execute("PRAGMA synchronous=FULL")
                db.execute("BEGIN IMMEDIATE")
            except BaseException:
                self._end("ROLLBACK")
                raise
            return db

        def __exit__(self, exc_type, exc, tb) -> None:
            self._end("COMMIT" if exc_type is None else "ROLLBACK")

        def _end(self, verb: str) -> None:
            outbox, db = self.outbox, self.outbox._db
            try:
                if db.in_transaction:
                    db.execute(verb)
                if verb == "COMMIT" and self.durable:
                    outbox._pending.clear()  # they are on disk now (_write_pending)
                    outbox._pending_evicted = 0
            finally:
                try:
                    if self.durable:
                        db.execute(f"PRAGMA synchronous={outbox._synchronous}")
                finally:
                    outbox._lock.release()

    def _tx(self, *, durable: bool = False) -> Outbox._Tx:
        """One transaction. A ``durable`` one is fsynced at commit and must carry the waiting
        fixes (:meth:`_write_pending`): they leave memory when it commits."""
        return Outbox._Tx(self, durable)

    def _write_pending(self, db: sqlite3.Connection) -> int:
        """Insert the waiting fixes, evict the oldest beyond ``max_fixes``; how many went."""
        if not self._pending:
            return 0
        db.executemany(
            "INSERT INTO outbox (kind, body, created_at) VALUES ('fix', ?, ?)", self._pending
        )
        self._bump(db, "recorded_fixes", len(self._pending) + self._pending_evicted)
        if self._pending_evicted:
            self._bump(db, "evicted_fixes", self._pending_evicted)
        (count,) = db.execute("SELECT COUNT(*) FROM outbox WHERE kind = 'fix'").fetchone()
        excess = count - self.max_fixes
        if excess > 0:
            db.execute(
                "DELETE FROM outbox WHERE id IN "
                "(SELECT id FROM outbox WHERE kind = 'fix' ORDER BY id LIMIT ?)",
                (excess,),
            )
            self._bump(db, "evicted_fixes", excess)
        return max(excess, 0)

    # -- fixes and acks -----------------------------------------------------------------------

    def add_fix(self, fix: dict[str, Any]) -> int:
        """Queue one fix; commit the waiting group once ``commit_every`` fixes wait.

        Returns how many of the oldest fixes that commit evicted (beyond ``max_fixes``).
        """
        body = json.dumps(fix, separators=(",", ":"), allow_nan=False)
        with self._lock:
            self._pending.append((body, time.time()))
            if len(self._pending) > self.max_fixes:
                # Commits keep failing (a dying SD card): memory holds no more than the disk
                # would, oldest out first, counted as evictions once a commit works again.
                del self._pending[0]
                self._pending_evicted += 1
            full = len(self._pending) >= self.commit_every
        return self.commit() if full else 0

    def commit(self) -> int:
        """Commit the waiting fixes in one durable transaction. Returns how many were evicted."""
        with self._lock:
            if not self._pending:
                return 0
        with self._tx(durable=True) as db:
            excess = self._write_pending(db)
        if excess > 0 and time.monotonic() - self._eviction_logged > EVICTION_LOG_EVERY_S:
            # Once full, every new fix evicts one: say so now and then, not every period.
            self._eviction_logged = time.monotonic()
            log.warning(
                "outbox full (%d fixes): evicting the oldest; %d evicted so far",
                self.max_fixes,
                self.counter("evicted_fixes"),
            )
        return excess

    def add_ack(self, uid: str, status: str, detail: str = "") -> None:
        # The shore refuses NUL and lone surrogates in any text (a 400, and such an ack would be
        # dropped); the autopilot's words may hold them, so they go as U+FFFD.
        detail = UNSENDABLE.sub("\ufffd", detail[:1000])
        body = json.dumps({"uid": uid, "status": status, "detail": detail})
        with self._tx(durable=True) as db:
            self._write_pending(db)  # the same fsync makes the waiting fixes durable too
            db.execute(
                "INSERT INTO outbox (kind, body, created_at) VALUES ('ack', ?, ?)",
                (body, time.time()),
            )

    def peek(self, kind: str, limit: int) -> list[Item]:
        """The oldest ``limit`` items of ``kind``. Fixes are committed first: none is sent
        before it is on disk."""
        if kind == "fix":
            self.commit()
        with self._lock:
            rows = self._db.execute(
                "SELECT id, kind, body FROM outbox WHERE kind = ? ORDER BY id LIMIT ?",
                (kind, limit),
            ).fetchall()
        return [Item(id=r[0], kind=r[1], body=json.loads(r[2])) for r in rows]

    def newest(self, kind: str, limit: int, after_id: int = 0) -> list[Item]:
        """The newest ``limit`` items of ``kind`` with an id above ``after_id``, newest first
        (the SBD fallback's pick). They stay queued. Fixes are committed first, as by peek."""
        if kind == "fix":
            self.commit()
        with self._lock:
            rows = self._db.execute(
                "SELECT id, kind, body FROM outbox WHERE kind = ? AND id > ? "
                "ORDER BY id DESC LIMIT ?",
                (kind, after_id, limit),
            ).fetchall()
        return [Item(id=r[0], kind=r[1], body=json.loads(r[2])) for r in rows]

    def set_fix_times(self, times: Sequence[tuple[int, Any]]) -> None:
        """Give queued fixes new ``time`` values ((id, time) pairs; a fix gone meanwhile is
        skipped): a fix also sent in a form that keeps whole seconds must reach the shore with
        that same time by every link, or the shore stores it twice (it dedupes on the time)."""
        with self._tx() as db:
            for item_id, value in times:
                row = db.execute(
                    "SELECT body FROM outbox WHERE id = ? AND kind = 'fix'", (item_id,)
                ).fetchone()
                if row is None:
                    continue
                body = json.loads(row[0])
                body["time"] = value
                db.execute(
                    "UPDATE outbox SET body = ? WHERE id = ?",
                    (json.dumps(body, separators=(",", ":"), allow_nan=False), item_id),
                )

    def remove(self, ids: Sequence[int]) -> None:
        if not ids:
            return
        with self._tx() as db:
            db.executemany("DELETE FROM outbox WHERE id = ?", [(i,) for i in ids])

    def count(self, kind: str | None = None) -> int:
        """Items queued, fixes still waiting for their commit included."""
        where, args = ("WHERE kind = ?", (kind,)) if kind else ("", ())
        with self._lock:
            waiting = len(self._pending) if kind in (None, "fix") else 0
            (stored,) = self._db.execute(f"SELECT COUNT(*) FROM outbox {where}", args).fetchone()
        return stored + waiting

    # -- counters -----------------------------------------------------------------------------

    @staticmethod
    def _bump(db: sqlite3.Connection, name: str, by: int = 1) -> None:
        db.execute(
            "INSERT INTO counters (name, value) VALUES (?, ?) "
            "ON CONFLICT(name) DO UPDATE SET value = value + excluded.value",
            (name, by),
        )

    def bump(self, name: str, by: int = 1) -> None:
        with self._tx() as db:
            self._bump(db, name, by)

    def counter(self, name: str) -> int:
        with self._lock:
            row = self._db.execute("SELECT value FROM counters WHERE name = ?", (name,)).fetchone()
        return row[0] if row else 0

    # -- command dedupe -----------------------------------------------------------------------

    def command_claim(self, uid: str, kind: str) -> bool:
        """Record that command ``uid`` is starting. False if it was seen before (don't run it)."""
        with self._tx(durable=True) as db:
            self._write_pending(db)
            cur = db.execute(
                "INSERT OR IGNORE INTO commands (uid, kind, state, updated_at) "
                "VALUES (?, ?, 'running', ?)",
                (uid, kind, time.time()),
            )
            return cur.rowcount == 1

    def command_finish(self, uid: str) -> None:
        with self._tx(durable=True) as db:
            self._write_pending(db)
            db.execute(
                "UPDATE commands SET state = 'finished', updated_at = ? WHERE uid = ?",
                (time.time(), uid),
            )

    def commands_interrupted(self) -> list[tuple[str, str]]:
        """(uid, kind) of commands that were running when the client last stopped."""
        with self._lock:
            return self._db.execute(
                "SELECT uid, kind FROM commands WHERE state = 'running' ORDER BY updated_at"
            ).fetchall()

    def commands_forget_old(self, now: float | None = None) -> None:
        cutoff = (now or time.time()) - COMMAND_MEMORY_S
        with self._tx() as db:
            db.execute(
                "DELETE FROM commands WHERE state = 'finished' AND updated_at < ?", (cutoff,)
            )
