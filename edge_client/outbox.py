"""Store-and-forward outbox on disk (sqlite3 from the standard library).

Every fix and every command ack is written here *before* any attempt to send it, and leaves only
when the server has answered for it (DESIGN §6). Properties this module is responsible for:

- Order: items go out oldest first (``id`` is an AUTOINCREMENT rowid, never reused).
- Bounded: at most ``max_fixes`` fixes; adding one more evicts the oldest, and the number evicted
  is kept in the ``counters`` table (it survives restarts and is logged and reported).
  Acks are never evicted: losing one would leave a command re-offered forever, and there are
  only ever a handful.
- Crash safety: WAL journal with ``synchronous=FULL``; every change is one transaction, so a
  process killed mid-write leaves the previous committed state (tested by SIGKILL mid-insert).
- Command dedupe: the ``commands`` table remembers every command uid the executor has started,
  so a command re-offered after a restart is not run again (the thesis' client re-ran a
  ``moveTo`` on every poll).

The pure decision "which outbox rows may leave after this server answer" is
:func:`settle_fix_batch`; this module's class only does storage.
"""

from __future__ import annotations

import json
import logging
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

    The answer is ``{"accepted": n, "duplicates": n, "rejected": [{"index": i, "errors": ...}]}``
    (DESIGN §5). Accepted and duplicate fixes are on the server; a rejected one never will be,
    so it is dropped too (after logging). If the answer does not account for every fix in the
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
    """The on-disk queue. Thread-safe: one connection guarded by a lock."""

    def __init__(self, path: str | Path, *, max_fixes: int = 100_000) -> None:
        self.path = str(path)
        self.max_fixes = max_fixes
        if self.path != ":memory:":
            Path(self.path).parent.mkdir(parents=True, exist_ok=True)
        self._lock = threading.Lock()
        self._eviction_logged = -EVICTION_LOG_EVERY_S
        # isolation_level=None: we issue BEGIN/COMMIT ourselves so each change is one transaction.
        self._db = sqlite3.connect(self.path, isolation_level=None, check_same_thread=False)
        self._db.execute("PRAGMA journal_mode=WAL")
        self._db.execute("PRAGMA synchronous=FULL")
        self._db.execute("PRAGMA busy_timeout=5000")
        for statement in SCHEMA.strip().split(";"):
            if statement.strip():
                self._db.execute(statement)

    def close(self) -> None:
        with self._lock:
            self._db.close()

    # -- transactions -------------------------------------------------------------------------

    class _Tx:
        def __init__(self, outbox: Outbox) -> None:
            self.outbox = outbox

        def __enter__(self) -> sqlite3.Connection:
            self.outbox._lock.acquire()
            self.outbox._db.execute("BEGIN IMMEDIATE")
            return self.outbox._db

        def __exit__(self, exc_type, exc, tb) -> None:
            try:
                self.outbox._db.execute("COMMIT" if exc_type is None else "ROLLBACK")
            finally:
                self.outbox._lock.release()

    def _tx(self) -> Outbox._Tx:
        return Outbox._Tx(self)

    # -- fixes and acks -----------------------------------------------------------------------

    def add_fix(self, fix: dict[str, Any]) -> int:
        """Store one fix; evict the oldest fixes beyond ``max_fixes``. Returns how many went."""
        body = json.dumps(fix, separators=(",", ":"), allow_nan=False)
        with self._tx() as db:
            db.execute(
                "INSERT INTO outbox (kind, body, created_at) VALUES ('fix', ?, ?)",
                (body, time.time()),
            )
            self._bump(db, "recorded_fixes")
            (count,) = db.execute("SELECT COUNT(*) FROM outbox WHERE kind = 'fix'").fetchone()
            excess = count - self.max_fixes
            if excess > 0:
                db.execute(
                    "DELETE FROM outbox WHERE id IN "
                    "(SELECT id FROM outbox WHERE kind = 'fix' ORDER BY id LIMIT ?)",
                    (excess,),
                )
                self._bump(db, "evicted_fixes", excess)
        if excess > 0 and time.monotonic() - self._eviction_logged > EVICTION_LOG_EVERY_S:
            # Once full, every new fix evicts one: say so now and then, not every period.
            self._eviction_logged = time.monotonic()
            log.warning(
                "outbox full (%d fixes): evicting the oldest; %d evicted so far",
                self.max_fixes,
                self.counter("evicted_fixes"),
            )
        return max(excess, 0)

    def add_ack(self, uid: str, status: str, detail: str = "") -> None:
        body = json.dumps({"uid": uid, "status": status, "detail": detail[:1000]})
        with self._tx() as db:
            db.execute(
                "INSERT INTO outbox (kind, body, created_at) VALUES ('ack', ?, ?)",
                (body, time.time()),
            )

    def peek(self, kind: str, limit: int) -> list[Item]:
        with self._lock:
            rows = self._db.execute(
                "SELECT id, kind, body FROM outbox WHERE kind = ? ORDER BY id LIMIT ?",
                (kind, limit),
            ).fetchall()
        return [Item(id=r[0], kind=r[1], body=json.loads(r[2])) for r in rows]

    def remove(self, ids: Sequence[int]) -> None:
        if not ids:
            return
        with self._tx() as db:
            db.executemany("DELETE FROM outbox WHERE id = ?", [(i,) for i in ids])

    def count(self, kind: str | None = None) -> int:
        with self._lock:
            if kind is None:
                return self._db.execute("SELECT COUNT(*) FROM outbox").fetchone()[0]
            return self._db.execute(
                "SELECT COUNT(*) FROM outbox WHERE kind = ?", (kind,)
            ).fetchone()[0]

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
        with self._tx() as db:
            cur = db.execute(
                "INSERT OR IGNORE INTO commands (uid, kind, state, updated_at) "
                "VALUES (?, ?, 'running', ?)",
                (uid, kind, time.time()),
            )
            return cur.rowcount == 1

    def command_finish(self, uid: str) -> None:
        with self._tx() as db:
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
