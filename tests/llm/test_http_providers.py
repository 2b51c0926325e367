"""The real OpenAI-compatible and Anthropic client code against a loopback chat server
(the ``fault_server`` fixture; tests/llm/test_faults.py drives it through every fault)."""

from __future__ import annotations

import pytest
from fault_server import FaultServer, answer, status

from regen.core.base import Answer
from regen.errors import MissingAPIKeyError, ProviderResponseError, ProviderUnreachableError
from regen.llm import LLM
from regen.llm.providers.anthropic import AnthropicProvider
from regen.llm.providers.keys import is_official
from regen.llm.providers.openai_compat import OpenAIProvider

KEY_VARS = ("OPENAI_API_KEY", "REGEN_OPENAI_API_KEY", "OPENAI_BASE_URL", "REGEN_OPENAI_BASE_URL",
            "ANTHROPIC_API_KEY", "REGEN_ANTHROPIC_API_KEY", "REGEN_ANTHROPIC_BASE_URL")
LEAK = "sk-should-never-leave"


class Causes(Answer):
    causes: list[str]


def _provider(fault_server: FaultServer, **kw) -> OpenAIProvider:
    return OpenAIProvider("test-model", base_url=fault_server.openai_url, api_key="sk-test-secret",
                          base_delay=0.01, **kw)


def test_success_sends_schema_and_key_and_counts_tokens(fault_server: FaultServer) -> None:
    fault_server.queue(answer('{"causes": ["debris"]}', usage=(40, 7)))
    llm = LLM(_provider(fault_server))
    assert llm.structured("why?", Causes).causes == ["debris"]
    req = fault_server.requests[0].body
    assert req["model"] == "test-model" and req["temperature"] == 0.0
    assert req["response_format"]["type"] == "json_schema"
    assert req["response_format"]["json_schema"]["schema"]["properties"]["causes"]["type"] == "array"
    assert fault_server.requests[0].headers["authorization"] == "Bearer sk-test-secret"
    assert (llm.stats.total.input_tokens, llm.stats.total.output_tokens) == (40, 7)


@pytest.mark.parametrize("first", [429, 500, 503])
def test_retryable_status_then_success(fault_server: FaultServer, first: int) -> None:
    fault_server.queue(status(first, retry_after=0), answer('{"causes": ["a"]}'))
    assert LLM(_provider(fault_server)).structured("q", Causes).causes == ["a"]
    assert len(fault_server.requests) == 2


def test_timeout_is_retried_then_reported(fault_server: FaultServer) -> None:
    fault_server.queue(*[answer('{"causes": []}', delay=1.0)] * 2)
    prov = _provider(fault_server, timeout=0.2, attempts=2)
    with pytest.raises(ProviderUnreachableError, match="failed after 2 attempts: timeout"):
        LLM(prov).structured("q", Causes)


def test_unreachable_base_url_is_reported() -> None:
    prov = OpenAIProvider("m", base_url="http://127.0.0.1:9/v1", attempts=2, base_delay=0.01)
    with pytest.raises(ProviderUnreachableError, match="cannot reach http://127.0.0.1:9/v1"):
        LLM(prov).structured("q", Causes)


def test_client_error_is_not_retried(fault_server: FaultServer) -> None:
    fault_server.queue(status(400, body={"error": {"message": "bad model"}}))
    with pytest.raises(ProviderResponseError, match="HTTP 400"):
        LLM(_provider(fault_server)).structured("q", Causes)
    assert len(fault_server.requests) == 1


@pytest.fixture
def clean_env(monkeypatch: pytest.MonkeyPatch) -> pytest.MonkeyPatch:
    for var in KEY_VARS:
        monkeypatch.delenv(var, raising=False)
    return monkeypatch


def _leaked(fault_server: FaultServer, secret: str) -> list[str]:
    """Every header line or request body of the server that carries ``secret``."""
    lines = [f"{k}: {v}" for r in fault_server.requests for k, v in r.header_items]
    bodies = [r.raw.decode() for r in fault_server.requests]
    return [x for x in lines + bodies if secret in x]


def _auth(fault_server: FaultServer, i: int = 0) -> list[str]:
    return [v for k, v in fault_server.requests[i].header_items
            if k.lower() in ("authorization", "x-api-key")]


def test_rejected_key_says_which_variable(fault_server: FaultServer, clean_env) -> None:
    clean_env.setenv("REGEN_OPENAI_API_KEY", "local-key")
    fault_server.queue(status(401))
    prov = OpenAIProvider("test-model", base_url=fault_server.openai_url, base_delay=0.01)
    with pytest.raises(MissingAPIKeyError, match="refused the API key.*check REGEN_OPENAI_API_KEY"):
        LLM(prov).structured("q", Causes)


def test_rejected_request_without_key_says_how_to_send_one(fault_server: FaultServer, clean_env) -> None:
    fault_server.queue(status(401))
    prov = OpenAIProvider("test-model", base_url=fault_server.openai_url, base_delay=0.01)
    with pytest.raises(MissingAPIKeyError, match="export REGEN_OPENAI_API_KEY"):
        LLM(prov).structured("q", Causes)


@pytest.mark.parametrize("url_var", ["REGEN_OPENAI_BASE_URL", "OPENAI_BASE_URL"])
def test_openai_key_never_goes_to_a_custom_base_url(fault_server: FaultServer, clean_env,
                                                     url_var: str) -> None:
    clean_env.setenv("OPENAI_API_KEY", LEAK)
    clean_env.setenv(url_var, fault_server.openai_url)
    fault_server.queue(answer('{"causes": ["a"]}'))
    assert LLM("openai:test-model").structured("q", Causes).causes == ["a"]
    assert len(fault_server.requests) == 1
    assert _leaked(fault_server, LEAK) == [] and _auth(fault_server) == []


def test_custom_base_url_gets_its_own_key(fault_server: FaultServer, clean_env) -> None:
    clean_env.setenv("OPENAI_API_KEY", LEAK)
    clean_env.setenv("REGEN_OPENAI_API_KEY", "local-key")
    clean_env.setenv("REGEN_OPENAI_BASE_URL", fault_server.openai_url)
    fault_server.queue(answer('{"causes": ["a"]}'))
    LLM("openai:test-model").structured("q", Causes)
    assert _auth(fault_server) == ["Bearer local-key"]
    assert _leaked(fault_server, LEAK) == []


def test_official_url_never_gets_the_custom_key(clean_env) -> None:
    # REGEN_OPENAI_API_KEY belongs to the custom server: OpenAI still asks for its own key
    clean_env.setenv("REGEN_OPENAI_API_KEY", "local-key")
    clean_env.setenv("REGEN_OPENAI_BASE_URL", "https://api.openai.com/v1/")
    with pytest.raises(MissingAPIKeyError, match="export OPENAI_API_KEY"):
        LLM("openai:gpt-4o-mini")


@pytest.mark.parametrize(("url", "official"), [
    ("https://api.openai.com/v1", True), ("https://API.openai.com/v1/", True),
    ("https://api.openai.com:443/v1", True),
    ("http://api.openai.com/v1", False), ("https://api.openai.com.example.test/v1", False),
    ("https://api.openai.com:8443/v1", False), ("http://localhost:8000/v1", False),
    ("not a url", False),
])
def test_official_means_same_scheme_host_and_port(url: str, official: bool) -> None:
    assert is_official(url, "https://api.openai.com/v1") is official


def test_missing_openai_key_says_how_to_set_it(clean_env) -> None:
    with pytest.raises(MissingAPIKeyError, match="export OPENAI_API_KEY"):
        LLM("openai:gpt-4o-mini")


def test_missing_anthropic_key_says_how_to_set_it(clean_env) -> None:
    with pytest.raises(MissingAPIKeyError, match="export ANTHROPIC_API_KEY"):
        LLM("anthropic:claude-sonnet-4-5")


def test_anthropic_key_never_goes_to_a_custom_url(fault_server: FaultServer, clean_env) -> None:
    clean_env.setenv("ANTHROPIC_API_KEY", LEAK)
    clean_env.setenv("REGEN_ANTHROPIC_BASE_URL", fault_server.anthropic_url)
    fault_server.queue(answer('{"causes": ["a"]}'))
    assert LLM("anthropic:claude-test").structured("q", Causes).causes == ["a"]
    assert len(fault_server.requests) == 1
    assert _leaked(fault_server, LEAK) == [] and _auth(fault_server) == []


def test_anthropic_custom_url_gets_its_own_key(fault_server: FaultServer, clean_env) -> None:
    clean_env.setenv("ANTHROPIC_API_KEY", LEAK)
    clean_env.setenv("REGEN_ANTHROPIC_API_KEY", "proxy-key")
    clean_env.setenv("REGEN_ANTHROPIC_BASE_URL", fault_server.anthropic_url)
    fault_server.queue(answer('{"causes": ["a"]}'))
    LLM("anthropic:claude-test").structured("q", Causes)
    assert _auth(fault_server) == ["proxy-key"]
    assert _leaked(fault_server, LEAK) == []


def test_anthropic_rejected_request_without_key(fault_server: FaultServer, clean_env) -> None:
    clean_env.setenv("REGEN_ANTHROPIC_BASE_URL", fault_server.anthropic_url)
    fault_server.queue(status(403))
    with pytest.raises(MissingAPIKeyError, match="export REGEN_ANTHROPIC_API_KEY"):
        LLM("anthropic:claude-test").structured("q", Causes)


def test_key_is_not_in_the_cache(fault_server: FaultServer, tmp_path) -> None:
    fault_server.queue(answer('{"causes": ["a"]}'))
    cache = tmp_path / "c.sqlite"
    LLM(_provider(fault_server), cache=cache).structured("q", Causes)
    for f in tmp_path.iterdir():
        assert b"sk-test-secret" not in f.read_bytes()


def test_anthropic_tool_answer(fault_server: FaultServer) -> None:
    fault_server.queue(answer('{"causes": ["ambulance"]}', usage=(9, 3)))
    prov = AnthropicProvider("claude-test", api_key="k", base_url=fault_server.anthropic_url,
                             base_delay=0.01)
    llm = LLM(prov)
    assert llm.structured([{"role": "system", "content": "be brief"}, {"role": "user", "content": "q"}],
                          Causes).causes == ["ambulance"]
    req = fault_server.requests[0].body
    assert req["system"] == "be brief" and req["tool_choice"] == {"type": "tool", "name": "answer"}
    assert fault_server.requests[0].headers["x-api-key"] == "k"
