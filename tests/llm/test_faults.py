"""The real LLM client, with both HTTP providers, against a server that misbehaves.

Every fault ends in one of three ways: retried and then answered, a clear RegenError subclass,
or a malformed answer that is re-asked. Never another exception type, never a cache entry that
breaks the next run.
"""

from __future__ import annotations

import json
import sqlite3
import time
from pathlib import Path

import pytest
from fault_server import (
    LONE_SURROGATE,
    EdgeJudgement,
    FaultServer,
    answer,
    deep,
    hang,
    huge_reason,
    raw,
    reset,
    status,
)

from regen.core.base import Answer
from regen.errors import (
    MalformedAnswerError,
    MissingAPIKeyError,
    ProviderResponseError,
    ProviderUnreachableError,
    RegenError,
)
from regen.llm import LLM
from regen.llm.base import Provider
from regen.llm.providers.anthropic import AnthropicProvider
from regen.llm.providers.openai_compat import OpenAIProvider
from regen.llm.sanitize import MAX_TEXT_CHARS

KINDS = ["openai", "anthropic"]
GOOD = '{"causes": ["debris on the road"]}'
TIMEOUT = 0.4  # [s] client timeout in these tests; a hang lasts longer



class Causes(Answer):
    causes: list[str]


def provider(kind: str, server: FaultServer, **kw) -> Provider:
    kw.setdefault("base_delay", 0.01)
    if kind == "openai":
        return OpenAIProvider("test-model", base_url=server.openai_url, api_key="sk-test", **kw)
    return AnthropicProvider("claude-test", base_url=server.anthropic_url, api_key="k", **kw)


def client(kind: str, server: FaultServer, cache: Path, **kw) -> LLM:
    return LLM(provider(kind, server, **kw), cache=cache, max_reasks=2)


def replayed(kind: str, server: FaultServer, cache: Path, schema=Causes):
    """Ask the same question again from the cache alone: it must not crash either."""
    return LLM(provider(kind, server), cache=cache, replay=True, max_reasks=2).structured("q", schema)


@pytest.fixture(params=KINDS)
def kind(request: pytest.FixtureRequest) -> str:
    return request.param


@pytest.fixture
def cache(tmp_path: Path) -> Path:
    return tmp_path / "llm-cache.sqlite"


def cached_rows(cache: Path) -> int:
    if not cache.exists():
        return 0
    with sqlite3.connect(cache) as db:
        return int(db.execute("SELECT COUNT(*) FROM calls").fetchone()[0])


# --- retried, then answered -------------------------------------------------------------------


@pytest.mark.parametrize("code", [429, 500, 502, 503, 529])
def test_busy_status_is_retried_then_answered(fault_server: FaultServer, kind: str, cache: Path,
                                              code: int) -> None:
    if code == 529 and kind == "openai":
        code = 503  # 529 is Anthropic's 'overloaded'
    fault_server.queue(status(code, retry_after=0), answer(GOOD))
    assert client(kind, fault_server, cache).structured("q", Causes).causes == ["debris on the road"]
    assert len(fault_server.requests) == 2
    assert replayed(kind, fault_server, cache).causes == ["debris on the road"]


@pytest.mark.parametrize("retry_after", ["-5", "nan", "soon", "1e999"])
def test_odd_retry_after_is_not_a_crash(fault_server: FaultServer, kind: str, cache: Path,
                                        retry_after: str) -> None:
    fault_server.queue(status(429, retry_after=retry_after), answer(GOOD))
    start = time.monotonic()
    assert client(kind, fault_server, cache).structured("q", Causes).causes
    assert time.monotonic() - start < 5


def test_connection_reset_is_retried_then_answered(fault_server: FaultServer, kind: str,
                                                   cache: Path) -> None:
    fault_server.queue(reset(), answer(GOOD))
    assert client(kind, fault_server, cache).structured("q", Causes).causes == ["debris on the road"]
    assert len(fault_server.requests) == 2


def test_one_hang_is_retried_then_answered(fault_server: FaultServer, kind: str, cache: Path) -> None:
    fault_server.queue(hang(), answer(GOOD))
    llm = client(kind, fault_server, cache, timeout=TIMEOUT)
    assert llm.structured("q", Causes).causes == ["debris on the road"]


# --- a clear error ----------------------------------------------------------------------------


def test_a_server_that_never_answers_is_given_up_in_bounded_time(fault_server: FaultServer,
                                                                  kind: str, cache: Path) -> None:
    fault_server.queue(hang(), hang(), hang())
    start = time.monotonic()
    with pytest.raises(ProviderUnreachableError, match="after 3 attempts: timeout"):
        client(kind, fault_server, cache, timeout=TIMEOUT, attempts=3).structured("q", Causes)
    assert time.monotonic() - start < 3 * TIMEOUT + 2
    assert len(fault_server.requests) == 3 and cached_rows(cache) == 0


def test_busy_to_the_end_is_unreachable(fault_server: FaultServer, kind: str, cache: Path) -> None:
    fault_server.queue(*[status(503, retry_after=0)] * 3)
    with pytest.raises(ProviderUnreachableError, match="after 3 attempts: HTTP 503"):
        client(kind, fault_server, cache, attempts=3).structured("q", Causes)
    assert cached_rows(cache) == 0


@pytest.mark.parametrize(("code", "error"), [(400, ProviderResponseError), (404, ProviderResponseError),
                                             (401, MissingAPIKeyError), (403, MissingAPIKeyError)])
def test_client_errors_are_not_retried(fault_server: FaultServer, kind: str, cache: Path, code: int,
                                       error: type[RegenError]) -> None:
    fault_server.queue(status(code), answer(GOOD))
    with pytest.raises(error):
        client(kind, fault_server, cache).structured("q", Causes)
    assert len(fault_server.requests) == 1 and cached_rows(cache) == 0


@pytest.mark.parametrize("body", [
    "<html>502 Bad Gateway</html>",  # not JSON
    '{"choices": [{"message": {"content": "x"',  # cut short
    "",  # empty
    b"\xff\xfe\x00garbage",  # not even UTF-8
    "[" * 100_000,  # the envelope itself nested too deep to parse
])
def test_a_200_reply_that_is_not_json_is_a_response_error(fault_server: FaultServer, kind: str,
                                                          cache: Path, body) -> None:
    fault_server.queue(raw(body, content_type="text/html"))
    with pytest.raises(ProviderResponseError, match="not JSON"):
        client(kind, fault_server, cache).structured("q", Causes)
    assert cached_rows(cache) == 0


@pytest.mark.parametrize("body", [
    [1, 2, 3],  # JSON, but no object
    {"choices": "none", "content": "none"},
    {"choices": [{"message": {"content": {"causes": ["a"]}}}],  # content is not text
     "content": [{"type": "text", "text": {"causes": ["a"]}}]},
    {"choices": [], "content": [7]},
    None,  # JSON null
])
def test_json_of_the_wrong_shape_is_a_response_error(fault_server: FaultServer, kind: str,
                                                     cache: Path, body) -> None:
    fault_server.queue(raw(json.dumps(body)))
    with pytest.raises(ProviderResponseError, match="not a"):
        client(kind, fault_server, cache).structured("q", Causes)
    assert cached_rows(cache) == 0


def test_a_reply_too_large_to_read_is_refused(fault_server: FaultServer, kind: str, cache: Path,
                                              monkeypatch: pytest.MonkeyPatch) -> None:
    from regen.llm.providers import http

    monkeypatch.setattr(http, "MAX_REPLY_BYTES", 100_000)
    fault_server.queue(answer(json.dumps({"causes": ["x" * 200_000]})))
    with pytest.raises(ProviderResponseError, match="larger than"):
        client(kind, fault_server, cache).structured("q", Causes)


def test_garbage_usage_counts_as_zero_tokens(fault_server: FaultServer, kind: str, cache: Path) -> None:
    envelope = {"choices": [{"message": {"content": GOOD}}], "usage": {"prompt_tokens": "many",
                                                                        "completion_tokens": 1e999},
                "content": [{"type": "text", "text": GOOD}], }
    envelope["usage"].update({"input_tokens": -3, "output_tokens": [1]})
    fault_server.queue(raw(json.dumps(envelope)))
    llm = client(kind, fault_server, cache)
    assert llm.structured("q", Causes).causes == ["debris on the road"]
    assert (llm.stats.total.input_tokens, llm.stats.total.output_tokens) == (0, 0)


# --- malformed: re-asked ----------------------------------------------------------------------


@pytest.mark.parametrize("bad", [
    '{"causes": ["a"',  # cut short
    '{"cause": ["a"]}',  # wrong key
    '{"causes": [NaN]}',  # not a finite number
    '{"causes": [1e999]}',
    deep(100_000),  # nested too deep to parse
    deep(200) + "]" * 200,  # parses, but deeper than any answer schema
    "1" * 5000,  # an integer Python refuses to parse
])
def test_malformed_answer_is_reasked(fault_server: FaultServer, kind: str, cache: Path, bad: str) -> None:
    fault_server.queue(answer(bad), answer(GOOD))
    got = client(kind, fault_server, cache).ask("q", Causes)
    assert got.value.causes == ["debris on the road"] and got.attempts == 2
    reask = fault_server.requests[1].body["messages"]
    assert reask[-1]["content"].startswith("Your answer is not valid")
    assert len(json.dumps(reask)) < 20_000  # the bad answer is echoed back cut, not whole
    assert replayed(kind, fault_server, cache).causes == ["debris on the road"]


def test_malformed_to_the_cap_is_a_malformed_answer_error(fault_server: FaultServer, kind: str,
                                                          cache: Path) -> None:
    fault_server.queue(answer(deep()), answer(deep()), answer(deep()))
    with pytest.raises(MalformedAnswerError, match="after 2 re-asks.*nested"):
        client(kind, fault_server, cache).structured("q", Causes)
    assert len(fault_server.requests) == 3
    with pytest.raises(MalformedAnswerError):  # the same from the cache, not a crash
        replayed(kind, fault_server, cache)


def test_a_provider_that_recovers_is_asked_again_by_the_next_run(fault_server: FaultServer, kind: str,
                                                                 cache: Path) -> None:
    fault_server.queue(answer("overloaded, try later"), answer("{}"), answer("[1]"))
    with pytest.raises(MalformedAnswerError):
        client(kind, fault_server, cache).structured("q", Causes)
    fault_server.queue(answer(GOOD))  # the provider works again
    got = client(kind, fault_server, cache).ask("q", Causes)  # "run the same command again"
    assert got.value.causes == ["debris on the road"] and not got.cached and got.attempts == 1
    assert len(fault_server.requests) == 4
    # and that answer is now what a rerun and a replay get, without the provider
    assert client(kind, fault_server, cache).ask("q", Causes).cached
    assert replayed(kind, fault_server, cache).causes == ["debris on the road"]
    assert len(fault_server.requests) == 4


def test_a_reask_cut_short_leaves_no_invalid_answer_for_the_rerun(fault_server: FaultServer, kind: str,
                                                                   cache: Path) -> None:
    fault_server.queue(answer("not json"), status(400))  # the re-ask itself fails
    with pytest.raises(ProviderResponseError):
        client(kind, fault_server, cache).structured("q", Causes)
    fault_server.queue(answer(GOOD))
    got = client(kind, fault_server, cache).ask("q", Causes)
    assert got.attempts == 1 and got.value.causes == ["debris on the road"]
    assert fault_server.requests[-1].body["messages"][-1]["content"] == "q"  # asked, not re-asked


def test_an_exchange_that_recovered_by_reasking_is_replayed_exactly(fault_server: FaultServer, kind: str,
                                                                    cache: Path) -> None:
    fault_server.queue(answer("not json"), answer(GOOD))
    first = client(kind, fault_server, cache).ask("q", Causes)
    assert first.attempts == 2
    for again in (client(kind, fault_server, cache),
                  LLM(provider(kind, fault_server), cache=cache, replay=True, max_reasks=2)):
        got = again.ask("q", Causes)
        assert (got.value, got.attempts, got.cached) == (first.value, 2, True)
        assert again.stats.total.reasks == 1 and again.stats.total.model_calls == 0
    assert len(fault_server.requests) == 2


# --- answers cleaned before they are cached ---------------------------------------------------


@pytest.mark.parametrize("content", [
    json.dumps({"causes": [LONE_SURROGATE]}, ensure_ascii=False),  # decoded by the HTTP layer
    json.dumps({"causes": [LONE_SURROGATE]}),  # a \\ud800 escape inside the answer's JSON
])
def test_lone_surrogate_is_replaced_before_caching(fault_server: FaultServer, kind: str, cache: Path,
                                                   content: str) -> None:
    fault_server.queue(answer(content))
    want = ["A pedestrian \ufffd crosses the road"]
    assert client(kind, fault_server, cache).structured("q", Causes).causes == want
    assert replayed(kind, fault_server, cache).causes == want  # the rerun reads the cache fine
    json.dumps(want, ensure_ascii=False).encode("utf-8")  # and it can be written to a file


def test_control_characters_are_removed(fault_server: FaultServer, kind: str, cache: Path) -> None:
    fault_server.queue(answer('{"causes": ["a\\u0000b\\u001b[31mc\\r\\nd\\te\\u0085f"]}'))
    assert client(kind, fault_server, cache).structured("q", Causes).causes == ["ab[31mc\nd\tef"]


def test_huge_string_is_cut_where_it_enters_the_data_model(fault_server: FaultServer, kind: str,
                                                           cache: Path) -> None:
    fault_server.queue(answer(huge_reason(2_000_000)))
    got = client(kind, fault_server, cache).structured("q", EdgeJudgement)
    reason = got.decisions[0].reason
    assert len(reason) == MAX_TEXT_CHARS and reason.endswith("\u2026")
    assert replayed(kind, fault_server, cache, EdgeJudgement).decisions[0].reason == reason


# --- the timeout option reaches the HTTP providers ---------------------------------------------


def test_timeout_option_reaches_the_provider(fault_server: FaultServer, kind: str,
                                             monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("REGEN_OPENAI_BASE_URL", fault_server.openai_url)
    monkeypatch.setenv("REGEN_ANTHROPIC_BASE_URL", fault_server.anthropic_url)
    fault_server.queue(hang(), answer(GOOD))
    llm = LLM(f"{kind}:test-model", timeout=TIMEOUT)
    assert llm.provider.timeout == TIMEOUT
    start = time.monotonic()
    assert llm.structured("q", Causes).causes == ["debris on the road"]
    assert time.monotonic() - start < 2.5


def test_timeout_from_the_environment(kind: str, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("REGEN_OPENAI_BASE_URL", "http://127.0.0.1:9/v1")
    monkeypatch.setenv("REGEN_ANTHROPIC_BASE_URL", "http://127.0.0.1:9/v1/messages")
    monkeypatch.setenv("REGEN_LLM_TIMEOUT", "7.5")
    assert LLM(f"{kind}:m").provider.timeout == 7.5
    assert LLM(f"{kind}:m", timeout=3).provider.timeout == 3  # the option wins


@pytest.mark.parametrize("value", ["soon", "0", "-1", "nan", "inf"])
def test_bad_timeout_in_the_environment_names_the_variable(kind: str, value: str,
                                                           monkeypatch: pytest.MonkeyPatch) -> None:
    from regen.errors import ConfigError

    monkeypatch.setenv("REGEN_OPENAI_BASE_URL", "http://127.0.0.1:9/v1")
    monkeypatch.setenv("REGEN_ANTHROPIC_BASE_URL", "http://127.0.0.1:9/v1/messages")
    monkeypatch.setenv("REGEN_LLM_TIMEOUT", value)
    with pytest.raises(ConfigError, match="REGEN_LLM_TIMEOUT"):
        LLM(f"{kind}:m")


def test_local_model_accepts_the_timeout_option() -> None:
    # one option for every provider; the in-process model has no request to abandon
    assert LLM("local", timeout=5).provider.id.startswith("local:")


def test_expand_command_has_an_llm_timeout_option(fault_server: FaultServer, tmp_path: Path,
                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    from typer.testing import CliRunner

    from regen.cli import app

    monkeypatch.setenv("REGEN_OPENAI_BASE_URL", fault_server.openai_url)
    fault_server.queue(hang(), status(400))  # the first try times out, the retry gives up
    start = time.monotonic()
    res = CliRunner().invoke(app, ["expand", "the ego-vehicle stops abruptly", "-d", "driving",
                                   "-o", str(tmp_path / "out"), "--llm", "openai:test-model",
                                   "--cache", str(tmp_path / "c.sqlite"), "--llm-timeout", "0.4"])
    assert res.exit_code == 2 and "HTTP 400" in res.output, res.output
    assert len(fault_server.requests) == 2
    assert time.monotonic() - start < 2.5  # the hang lasts 3 s: the option was used


def test_the_fault_server_bounds_itself() -> None:
    import httpx

    with FaultServer(max_requests=1) as server:
        server.queue(answer(GOOD), answer(GOOD))
        assert httpx.post(server.openai_url + "/chat/completions", json={}).status_code == 200
        with pytest.raises(httpx.TransportError):  # over the request cap: reset at once
            httpx.post(server.openai_url + "/chat/completions", json={})
    with FaultServer(lifetime=0.2) as server:
        time.sleep(0.5)  # it stopped by itself
        with pytest.raises(httpx.TransportError):
            httpx.post(server.openai_url + "/chat/completions", json={}, timeout=1)
