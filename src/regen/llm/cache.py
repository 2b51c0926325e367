"""SQLite cache of model calls, keyed by a hash of everything that determines the answer.

The key covers provider, model, messages, JSON schema and sampling settings, never API keys.
Entries store the raw answer text with token counts and latency, so a replayed run reports the
same usage as the original one.
"""

from __future__ import annotations

import hashlib
import json
import sqlite3
import threading
import time
from dataclasses import asdict
from pathlib import Path
from typing import Any

from regen.errors import CacheCorruptedError
from regen.llm.base import Completion, Message, Sampling

_SCHEMA = """
CREATE TABLE IF NOT EXISTS calls (
    key TEXT PRIMARY KEY,
    provider TEXT NOT NULL,
    purpose TEXT NOT NULL,
    response TEXT NOT NULL,
    input_tokens INTEGER NOT NULL,
    output_tokens INTEGER NOT NULL,
    latency REAL NOT NULL,
    created REAL NOT NULL
)
"""


def cache_key(provider_id: str, messages: list[Message], schema: dict[str, Any] | None,
              sampling: Sampling) -> str:
    payload = json.dumps({"provider": provider_id, "messages": messages, "schema": schema,
                          "sampling": asdict(sampling)}, sort_keys=True, ensure_ascii=False)
    return hashlib.sha256(payload.encode("utf-8")).hexdigest()


class CallCache:
    """A thread-safe SQLite cache file. ``CallCache(None)`` keeps entries in memory only."""

    def __init__(self, path: str | Path | None):
        self.path = Path(path) if path else None
        self._lock = threading.Lock()
        target = ":memory:"
        if self.path is not None:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            target = str(self.path)
        try:
            self._db = sqlite3.connect(target, check_same_thread=False, timeout=30)
            self._db.execute("PRAGMA journal_mode=WAL" if self.path else "PRAGMA journal_mode=MEMORY")
            self._db.execute(_SCHEMA)
            self._db.commit()
            self._db.execute("SELECT key FROM calls LIMIT 1").fetchall()
        except sqlite3.DatabaseError as exc:
            raise CacheCorruptedError(
                f"the LLM cache {self.path} is not a readable cache ({exc}); move or delete it "
                "and run again (cached answers in it are lost; a replay run needs them)") from None

    def get(self, key: str) -> tuple[Completion, float] | None:
        """The stored completion and its original latency [s], or None."""
        try:
            with self._lock:
                row = self._db.execute(
                    "SELECT response, input_tokens, output_tokens, latency FROM calls WHERE key = ?",
                    (key,)).fetchone()
        except sqlite3.DatabaseError as exc:
            raise CacheCorruptedError(f"the LLM cache {self.path} cannot be read ({exc}); "
                                      "move or delete it and run again") from None
        if row is None:
            return None
        return Completion(text=row[0], input_tokens=row[1], output_tokens=row[2]), float(row[3])

    def put(self, key: str, provider_id: str, purpose: str, completion: Completion, latency: float) -> None:
        with self._lock:
            self._db.execute(
                "INSERT OR REPLACE INTO calls VALUES (?, ?, ?, ?, ?, ?, ?, ?)",
                (key, provider_id, purpose, completion.text, completion.input_tokens,
                 completion.output_tokens, latency, time.time()))
            self._db.commit()

    def export_json(self, path: str | Path) -> int:
        """Write all entries to a JSON cassette (for recorded-answer tests); returns the count."""
        with self._lock:
            rows = self._db.execute("SELECT key, provider, purpose, response, input_tokens, "
                                    "output_tokens, latency FROM calls ORDER BY created").fetchall()
        cols = ("key", "provider", "purpose", "response", "input_tokens", "output_tokens", "latency")
        Path(path).write_text(json.dumps([dict(zip(cols, r, strict=True)) for r in rows], indent=1))
        return len(rows)

    def import_json(self, path: str | Path) -> int:
        """Load a JSON cassette written by :meth:`export_json`; returns the count."""
        rows = json.loads(Path(path).read_text())
        for r in rows:
            self.put(r["key"], r["provider"], r["purpose"],
                     Completion(r["response"], r["input_tokens"], r["output_tokens"]), r["latency"])
        return len(rows)

    def __len__(self) -> int:
        with self._lock:
            return int(self._db.execute("SELECT COUNT(*) FROM calls").fetchone()[0])

    def close(self) -> None:
        with self._lock:
            self._db.close()
