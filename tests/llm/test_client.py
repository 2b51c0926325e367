from __future__ import annotations

import json
import threading
import time
from pathlib import Path

import pytest

from regen.core.base import Answer
from regen.errors import (
    CacheCorruptedError,
    CacheMissError,
    ConfigError,
    MalformedAnswerError,
    UnknownProviderError,
)
from regen.llm import LLM, get_provider
from regen.llm.base import Completion, Provider, Sampling
from regen.llm.cache import CallCache
from regen.llm.json_extract import extract_json
from regen.llm.testing import QueuedProvider


class Causes(Answer):
    causes: list[str]


def test_structured_call_reasks_once_with_the_validation_error() -> None:
    prov = QueuedProvider(['{"cause": ["x"]}', 'Sure! ```json\n{"causes": ["a jaywalker"]}\n```'])
    llm = LLM(prov)
    got = llm.ask("why did the ego stop?", Causes, purpose="events")
    assert got.value.causes == ["a jaywalker"] and got.attempts == 2
    reask = prov.requests[1]
    assert reask[-2] == {"role": "assistant", "content": '{"cause": ["x"]}'}
    assert "causes" in reask[-1]["content"] and "not valid" in reask[-1]["content"]
    assert llm.stats.total.reasks == 1 and llm.stats.by_purpose["events"].calls == 2


def test_malformed_after_the_cap_raises_with_advice() -> None:
    llm = LLM(QueuedProvider(["no json here", "{}", "[1]"]), max_reasks=2)
    with pytest.raises(MalformedAnswerError, match="after 2 re-asks.*stronger model"):
        llm.structured("q", Causes)
    assert llm.stats.total.failures == 1


def test_cache_hit_miss_and_replay_miss(tmp_path: Path) -> None:
    cache = tmp_path / "llm.sqlite"
    first = LLM(QueuedProvider(['{"causes": ["debris"]}']), cache=cache)
    assert first.ask("q", Causes).cached is False
    # same request again: served from the cache, the provider is not asked (its queue is empty)
    second = LLM(QueuedProvider([]), cache=cache)
    hit = second.ask("q", Causes)
    assert hit.cached and hit.value.causes == ["debris"]
    assert second.stats.total.cache_hits == 1 and second.stats.total.model_calls == 0
    # a different request misses; in replay mode that is an error, not a call
    replay = LLM(QueuedProvider(['{"causes": ["never sent"]}']), cache=cache, replay=True)
    with pytest.raises(CacheMissError, match="Run without --replay"):
        replay.ask("another question", Causes)
    assert replay.provider.requests == []


def test_cache_key_depends_on_sampling(tmp_path: Path) -> None:
    cache = CallCache(tmp_path / "c.sqlite")
    LLM(QueuedProvider(['{"causes": []}']), cache=cache).ask("q", Causes)
    hot = LLM(QueuedProvider(['{"causes": ["hot"]}']), cache=cache, sampling=Sampling(temperature=0.7))
    assert hot.ask("q", Causes).cached is False


def test_corrupted_cache_file_is_a_clear_error(tmp_path: Path) -> None:
    bad = tmp_path / "llm.sqlite"
    bad.write_bytes(b"this is not a database" * 100)
    with pytest.raises(CacheCorruptedError, match="move or delete it"):
        LLM(QueuedProvider([]), cache=bad)


def test_unknown_provider_lists_the_choices() -> None:
    with pytest.raises(UnknownProviderError, match="openai:<model>"):
        get_provider("gemini:pro")


def test_extract_json_finds_object_in_chatter() -> None:
    assert extract_json('Here you go: {"a": [1, 2]} hope it helps') == {"a": [1, 2]}
    with pytest.raises(ValueError):
        extract_json("nothing")


class _SlowProvider(Provider):
    name = "slow"
    model = "m"

    def __init__(self) -> None:
        self.active = 0
        self.peak = 0
        self.lock = threading.Lock()

    def complete(self, messages, *, schema, sampling) -> Completion:
        with self.lock:
            self.active += 1
            self.peak = max(self.peak, self.active)
        time.sleep(0.05)
        with self.lock:
            self.active -= 1
        return Completion(text=json.dumps({"causes": [messages[-1]["content"]]}))


def test_map_runs_independent_calls_concurrently_within_the_limit() -> None:
    prov = _SlowProvider()
    llm = LLM(prov, concurrency=3)
    out = llm.map(lambda q: llm.structured(q, Causes).causes[0], [f"q{i}" for i in range(9)])
    assert out == [f"q{i}" for i in range(9)]  # order kept
    assert prov.peak == 3


def test_map_serializes_a_non_concurrent_provider() -> None:
    prov = _SlowProvider()
    prov.concurrent = False
    llm = LLM(prov, concurrency=4)
    llm.map(lambda q: llm.structured(q, Causes), ["a", "b", "c"])
    assert prov.peak == 1


def test_options_for_a_provider_object_are_refused_not_ignored() -> None:
    # a timeout given next to a built provider used to be dropped without a word
    with pytest.raises(ConfigError, match=r"^timeout: a provider object is already built; pass these to its"):
        LLM(QueuedProvider([]), timeout=5.0)
    with pytest.raises(ConfigError, match=r"^timeout, base_url: "):
        LLM(QueuedProvider([]), timeout=5.0, base_url="http://127.0.0.1:1")
    LLM(QueuedProvider([]))  # nothing to apply: fine


def test_a_cache_written_before_failed_answers_were_marked_still_serves(tmp_path: Path) -> None:
    import sqlite3

    from regen.llm.base import Sampling as S
    from regen.llm.cache import cache_key

    path = tmp_path / "old.sqlite"
    prov = QueuedProvider([])
    key = cache_key(prov.id, [{"role": "user", "content": "q"}], Causes.model_json_schema(), S())
    with sqlite3.connect(path) as db:  # the table as older versions made it: no 'failed' column
        db.execute("CREATE TABLE calls (key TEXT PRIMARY KEY, provider TEXT NOT NULL, purpose TEXT "
                   "NOT NULL, response TEXT NOT NULL, input_tokens INTEGER NOT NULL, output_tokens "
                   "INTEGER NOT NULL, latency REAL NOT NULL, created REAL NOT NULL)")
        db.execute("INSERT INTO calls VALUES (?, 'queued:test', 'call', ?, 1, 1, 0.1, 0)",
                   (key, '{"causes": ["old"]}'))
    got = LLM(prov, cache=path).ask("q", Causes)
    assert got.cached and got.value.causes == ["old"]
    LLM(QueuedProvider(['{"causes": ["new"]}']), cache=path).ask("other", Causes)  # and writes


def test_a_full_cache_file_is_a_full_disk(tmp_path: Path) -> None:
    import errno

    cache = CallCache(tmp_path / "c.sqlite")
    cache._db.execute("PRAGMA max_page_count = 8")  # the file cannot grow: as on a full disk
    with pytest.raises(OSError) as err:
        for i in range(200):
            cache.put(f"k{i}", "p", "call", Completion(text="x" * 4000), 0.1)
    assert err.value.errno == errno.ENOSPC and str(tmp_path / "c.sqlite") == err.value.filename


def test_a_schema_is_made_once_per_model_class_and_handed_out_fresh(monkeypatch) -> None:
    from pydantic import BaseModel as _Base

    from regen.llm.client import json_schema_of

    class Reply(_Base):
        name: str
        count: int = 0

    made = []
    real = Reply.model_json_schema.__func__

    def counted(cls, *a, **k):
        made.append(cls)
        return real(cls, *a, **k)

    monkeypatch.setattr(Reply, "model_json_schema", classmethod(counted))
    first = json_schema_of(Reply)
    assert first == real(Reply) and made == [Reply]
    first["properties"]["name"]["type"] = "integer"  # a caller's change stays its own
    again = json_schema_of(Reply)
    assert again == real(Reply) and again is not first and made == [Reply]
