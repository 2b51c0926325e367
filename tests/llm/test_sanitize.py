"""Answers are cleaned once, at the LLM boundary, before they are cached or validated."""

from __future__ import annotations

import json
import sqlite3
from pathlib import Path

import pytest
from fault_server import EdgeJudgement

from regen.core.base import Answer
from regen.errors import MalformedAnswerError
from regen.llm import LLM
from regen.llm.cache import CallCache
from regen.llm.json_extract import MAX_DEPTH, extract_json
from regen.llm.sanitize import ELLIPSIS, MAX_TEXT_CHARS, clean_text, clean_value
from regen.llm.testing import QueuedProvider

SURROGATE_JSON = '{"causes": ["A pedestrian \\ud800 crosses the road"]}'  # as the model wrote it
CLEAN = ["A pedestrian \ufffd crosses the road"]



class Causes(Answer):
    causes: list[str]


def test_clean_text_replaces_surrogates_and_drops_controls() -> None:
    assert clean_text("a\ud800b\udfffc") == "a\ufffdb\ufffdc"
    assert clean_text("ok \U0001f600") == "ok \U0001f600"  # a real astral character stays
    assert clean_text('{"a":\r\n\t"b\x00\x1b[1m\x7f\x9f"}') == '{"a":\r\n\t"b[1m"}'
    # bidi overrides and isolates reorder what a terminal or page shows: dropped; a zero-width
    # joiner inside an emoji sequence is text and stays
    assert clean_text("a\u202eexe.txt\u202c \u2066b\u2069") == "aexe.txt b"
    assert clean_text("\U0001f468\u200d\U0001f469") == "\U0001f468\u200d\U0001f469"


def test_clean_value_cleans_and_cuts_every_string_and_key() -> None:
    long = "y" * (MAX_TEXT_CHARS + 10)
    got = clean_value({"k\x00": ["a\ud800", {"r": long, long: 1}], "n": 2.5, "t": True, "z": None})
    assert got["k"][0] == "a\ufffd"
    inner = got["k"][1]
    assert inner["r"] == "y" * (MAX_TEXT_CHARS - 1) + ELLIPSIS
    assert "y" * (MAX_TEXT_CHARS - 1) + ELLIPSIS in inner
    assert (got["n"], got["t"], got["z"]) == (2.5, True, None)
    assert clean_value("a\r\nb") == "a\nb"  # values keep only \n and \t


def test_a_string_at_the_limit_is_kept_whole() -> None:
    assert clean_value("x" * MAX_TEXT_CHARS) == "x" * MAX_TEXT_CHARS


def test_extract_json_rejects_deep_nesting_as_malformed() -> None:
    with pytest.raises(ValueError, match="nested"):
        extract_json("[" * 100_000)
    with pytest.raises(ValueError, match="nested"):
        extract_json("[" * (MAX_DEPTH + 1) + "]" * (MAX_DEPTH + 1))
    assert extract_json("[" * MAX_DEPTH + "]" * MAX_DEPTH) is not None
    with pytest.raises(ValueError, match="nested"):  # also inside chatter
        extract_json("Sure: " + '{"a": ' * 5000 + "1" + "}" * 5000)


def test_extract_json_rejects_non_finite_numbers() -> None:
    for text in ('{"a": NaN}', '{"a": -Infinity}', '{"a": 1e999}'):
        with pytest.raises(ValueError, match="finite"):
            extract_json(text)


def test_extract_json_tries_a_bounded_number_of_starts(monkeypatch: pytest.MonkeyPatch) -> None:
    from regen.llm import json_extract

    tries = []

    class Counting(json.JSONDecoder):
        def raw_decode(self, s, idx=0):
            tries.append(idx)
            return super().raw_decode(s, idx)

    monkeypatch.setattr(json_extract, "_DECODER", Counting())
    # every '[' starts a parse that runs to the end of the text: quadratic without a bound
    with pytest.raises(ValueError, match="no JSON"):
        extract_json(('["' + "x" * 1000 + '", ') * 200)
    assert 0 < len(tries) <= 1 + json_extract.MAX_STARTS  # the whole text, then the starts


def test_lone_surrogate_in_the_answer_text_is_replaced_before_caching(tmp_path: Path) -> None:
    cache = tmp_path / "c.sqlite"
    decoded = SURROGATE_JSON.replace("\\ud800", "\ud800")  # the HTTP layer decoded the escape
    assert LLM(QueuedProvider([decoded]), cache=cache).structured("q", Causes).causes == CLEAN
    # the rerun is served from the cache, which holds the cleaned text
    assert LLM(QueuedProvider([]), cache=cache).structured("q", Causes).causes == CLEAN


def test_lone_surrogate_escape_in_the_answer_json_is_replaced(tmp_path: Path) -> None:
    llm = LLM(QueuedProvider([SURROGATE_JSON]), cache=tmp_path / "c.sqlite")
    assert llm.structured("q", Causes).causes == CLEAN


def test_a_cache_that_already_holds_invalid_text_is_read(tmp_path: Path) -> None:
    path = tmp_path / "c.sqlite"
    LLM(QueuedProvider(['{"causes": ["x"]}']), cache=path).structured("q", Causes)
    # what another tool (or an older version) may have left: a surrogate as CESU-8 bytes
    with sqlite3.connect(path) as db:
        db.execute("UPDATE calls SET response = CAST(? AS TEXT)",
                   (b'{"causes": ["A pedestrian ' + b"\xed\xa0\x80" + b' crosses the road"]}',))
    got = LLM(QueuedProvider([]), cache=path).ask("q", Causes)
    assert got.cached and got.value.causes == ["A pedestrian \ufffd\ufffd\ufffd crosses the road"]
    assert CallCache(path).export_json(tmp_path / "cassette.json") == 1


def test_a_cassette_with_a_surrogate_escape_is_imported_clean(tmp_path: Path) -> None:
    cassette = tmp_path / "cassette.json"
    cassette.write_text(json.dumps([{"key": "k", "provider": "p", "purpose": "q",
                                     "response": "a \ud800 b", "input_tokens": 1,
                                     "output_tokens": 1, "latency": 0.1}]))
    cache = CallCache(tmp_path / "c.sqlite")
    assert cache.import_json(cassette) == 1
    assert cache.get("k")[0].text == "a \ufffd b"


def test_deep_nesting_is_reasked_then_malformed() -> None:
    prov = QueuedProvider(["[" * 100_000] * 3)
    with pytest.raises(MalformedAnswerError, match="nested"):
        LLM(prov, max_reasks=2).structured("q", Causes)
    assert len(prov.requests) == 3
    # the re-ask shows the model a cut copy of its answer, not 100 000 brackets
    assert all(len(m["content"]) < 10_000 for m in prov.requests[-1])


def test_huge_reason_is_cut_with_an_ellipsis() -> None:
    big = json.dumps({"decisions": [{"candidate": "rain", "plausible": True, "reason": "x" * 2_000_000}]})
    got = LLM(QueuedProvider([big])).structured("q", EdgeJudgement)
    assert got.decisions[0].reason == "x" * (MAX_TEXT_CHARS - 1) + ELLIPSIS
    assert got.decisions[0].candidate == "rain"


def test_a_problem_message_stays_short() -> None:
    long_key = "k" * 100_000
    prov = QueuedProvider([json.dumps({long_key: 1})] * 2)
    with pytest.raises(MalformedAnswerError) as err:
        LLM(prov, max_reasks=1).structured("q", Causes)
    assert len(str(err.value)) < 2_000
