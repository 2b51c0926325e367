"""SQLite cache of model calls, keyed by a hash of everything that determines the answer.

The key covers provider, model, messages, JSON schema and sampling settings, never API keys.
A message's images enter it as their SHA-256 (a different image is a different call); neither
the key nor the entry holds an image's bytes. A text-only message hashes as it always has.
Entries store the answer text (as cleaned by the client) with token counts and latency, so a
replayed run reports the same usage as the original one.

An answer that failed validation and was never followed by a valid re-ask is marked ``failed``:
a later invocation that may call the model does not get it (the provider is asked again, so a
provider that has recovered is given its chance), while a replay, which exists to reproduce a
recorded run and cannot ask anyway, still gets it. The invalid answers of a call that recovered
by re-asking are not marked: a rerun replays that exchange exactly. Text that is not valid UTF-8 in a file
(written by another tool or an older version) is read with U+FFFD in place of the bad bytes.
"""

from __future__ import annotations

import errno
import hashlib
import json
import sqlite3
import threading
import time
from collections.abc import Iterable
from dataclasses import asdict
from pathlib import Path
from typing import Any

from regen.errors import CacheCorruptedError, ConfigError
from regen.llm.base import Completion, Message, Sampling, images_of
from regen.llm.sanitize import clean_text
from regen.promises.folders import make_folder

_SCHEMA = """
CREATE TABLE IF NOT EXISTS calls (
    key TEXT PRIMARY KEY,
    provider TEXT NOT NULL,
    purpose TEXT NOT NULL,
    response TEXT NOT NULL,
    input_tokens INTEGER NOT NULL,
    output_tokens INTEGER NOT NULL,
    latency REAL NOT NULL,
    created REAL NOT NULL,
    failed INTEGER NOT NULL DEFAULT 0
)
"""
_COLUMNS = "key, provider, purpose, response, input_tokens, output_tokens, latency, created, failed"


def _keyed(message: Message) -> dict[str, Any]:
    """``message`` as the cache key reads it: images as ``sha256:<hex>`` of their bytes, and a
    message without images (or with an empty list) exactly as one that never had the field."""
    images = images_of(message)
    keyed: dict[str, Any] = {k: v for k, v in message.items() if k != "images"}
    if images:
        keyed["images"] = ["sha256:" + hashlib.sha256(png).hexdigest() for png in images]
    return keyed


def cache_key(provider_id: str, messages: list[Message], schema: dict[str, Any] | None,
              sampling: Sampling) -> str:
    payload = json.dumps({"provider": provider_id, "messages": [_keyed(m) for m in messages],
                          "schema": schema, "sampling": asdict(sampling)},
                         sort_keys=True, ensure_ascii=False)
    # surrogatepass: a prompt may carry a lone surrogate (undecodable bytes in a command-line
    # argument); valid text hashes exactly as with plain UTF-8
    return hashlib.sha256(payload.encode("utf-8", "surrogatepass")).hexdigest()


def _lenient_text(data: bytes) -> str:
    return data.decode("utf-8", "replace")


def _count(value: Any) -> int:
    return value if isinstance(value, int) and value >= 0 else 0


class CallCache:
    """A thread-safe SQLite cache file. ``CallCache(None)`` keeps entries in memory only."""

    def __init__(self, path: str | Path | None):
        self.path = Path(path) if path else None
        self._lock = threading.Lock()
        target = ":memory:"
        if self.path is not None:
            self._check_place(self.path)
            target = str(self.path)
        try:
            self._db = sqlite3.connect(target, check_same_thread=False, timeout=30)
            self._db.text_factory = _lenient_text
            self._db.execute("PRAGMA journal_mode=WAL" if self.path else "PRAGMA journal_mode=MEMORY")
            self._db.execute(_SCHEMA)
            columns = {row[1] for row in self._db.execute("PRAGMA table_info(calls)")}
            if "failed" not in columns:  # a cache written before failed answers were marked
                self._db.execute("ALTER TABLE calls ADD COLUMN failed INTEGER NOT NULL DEFAULT 0")
            self._db.commit()
            self._db.execute("SELECT key FROM calls LIMIT 1").fetchall()
        except sqlite3.DatabaseError as exc:
            raise CacheCorruptedError(
                f"the LLM cache {self.path} is not a readable cache ({exc}); move or delete it "
                "and run again (cached answers in it are lost; a replay run needs them)") from None

    @staticmethod
    def _check_place(path: Path) -> None:
        """Make the cache file's folder; ConfigError on one line for a folder in the file's place
        or a file on its path (the cache is a file the user may name with --cache)."""
        if path.is_dir():
            raise ConfigError(f"the LLM cache {path} is a folder: give the path of a cache file, e.g. "
                              f"{path / 'llm-cache.sqlite'}")
        problem = make_folder(path.parent)
        if problem in ("file", "under_file"):
            raise ConfigError(f"the LLM cache {path} lies under a file ({path.parent} cannot be a folder): "
                              "give the path of a cache file in a folder")
        if problem not in (None, "not_writable"):  # a read-only folder: SQLite says what it can do
            raise ConfigError(f"cannot make the folder of the LLM cache {path} ({problem}): give the path of "
                              "a cache file in a writable folder")

    def get(self, key: str, *, failed: bool = False) -> tuple[Completion, float] | None:
        """The stored completion and its original latency [s], or None; an answer marked failed
        only with ``failed=True`` (a replay)."""
        try:
            with self._lock:
                row = self._db.execute(
                    "SELECT response, input_tokens, output_tokens, latency, failed FROM calls WHERE key = ?",
                    (key,)).fetchone()
        except sqlite3.DatabaseError as exc:
            raise CacheCorruptedError(f"the LLM cache {self.path} cannot be read ({exc}); "
                                      "move or delete it and run again") from None
        if row is None or (row[4] and not failed):
            return None
        text, tokens_in, tokens_out, latency, _ = row
        if isinstance(text, bytes):  # stored as a blob by another tool
            text = _lenient_text(text)
        if not isinstance(text, str):
            return None  # unusable: the call is made again and the entry overwritten
        return (Completion(text=text, input_tokens=_count(tokens_in), output_tokens=_count(tokens_out)),
                float(latency) if isinstance(latency, int | float) else 0.0)

    def _write(self, sql: str, rows: list[tuple[Any, ...]]) -> None:
        """Run one writing statement; a full disk or a read-only file is an OSError like any
        other file's (sqlite3 says it in its own words), so that callers treat it alike."""
        try:
            with self._lock:
                self._db.executemany(sql, rows)
                self._db.commit()
        except sqlite3.OperationalError as exc:
            code = getattr(exc, "sqlite_errorcode", None)
            if code is not None:
                code &= 0xFF  # the primary result code of an extended one
            if code == sqlite3.SQLITE_FULL:
                raise OSError(errno.ENOSPC, "No space left on device", str(self.path)) from exc
            if code == sqlite3.SQLITE_READONLY:
                raise OSError(errno.EROFS, "the model cache is read-only", str(self.path)) from exc
            raise

    def put(self, key: str, provider_id: str, purpose: str, completion: Completion, latency: float,
            *, failed: bool = False) -> None:
        self._write(f"INSERT OR REPLACE INTO calls ({_COLUMNS}) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)",
                    [(key, provider_id, purpose, completion.text, completion.input_tokens,
                      completion.output_tokens, latency, time.time(), int(failed))])

    def mark(self, keys: Iterable[str], *, failed: bool) -> None:
        """Mark the answers under ``keys`` as failed validation (or no longer failed: their call
        recovered by re-asking)."""
        rows = [(int(failed), k) for k in keys]
        if rows:
            self._write("UPDATE calls SET failed = ? WHERE key = ?", rows)

    def export_json(self, path: str | Path) -> int:
        """Write all entries to a JSON cassette (for recorded-answer tests); returns the count."""
        with self._lock:
            rows = self._db.execute("SELECT key, provider, purpose, response, input_tokens, "
                                    "output_tokens, latency, failed FROM calls ORDER BY created").fetchall()
        cols = ("key", "provider", "purpose", "response", "input_tokens", "output_tokens", "latency")
        out = []
        for r in rows:
            entry = dict(zip(cols, r[:-1], strict=True))
            if r[-1]:  # only where set: cassettes without failed answers stay as they were
                entry["failed"] = True
            out.append(entry)
        Path(path).write_text(json.dumps(out, indent=1), encoding="utf-8")
        return len(rows)

    def import_json(self, path: str | Path) -> int:
        """Load a JSON cassette written by :meth:`export_json`; returns the count.

        A cassette is edited by hand at times, so its answers are cleaned like a model's."""
        rows = json.loads(Path(path).read_text(encoding="utf-8"))
        for r in rows:
            self.put(r["key"], r["provider"], r["purpose"],
                     Completion(clean_text(r["response"]), r["input_tokens"], r["output_tokens"]),
                     r["latency"], failed=bool(r.get("failed", False)))
        return len(rows)

    def __len__(self) -> int:
        with self._lock:
            return int(self._db.execute("SELECT COUNT(*) FROM calls").fetchone()[0])

    def close(self) -> None:
        with self._lock:
            self._db.close()
