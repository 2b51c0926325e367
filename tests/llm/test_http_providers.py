"""The real OpenAI-compatible and Anthropic client code against a loopback chat server."""

from __future__ import annotations

import json
import threading
import time
from collections.abc import Iterator
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

import pytest

from regen.core.base import Answer
from regen.errors import MissingAPIKeyError, ProviderResponseError, ProviderUnreachableError
from regen.llm import LLM
from regen.llm.providers.anthropic import AnthropicProvider
from regen.llm.providers.openai_compat import OpenAIProvider


class Causes(Answer):
    causes: list[str]


class ChatServer:
    """Loopback server speaking chat completions; answers from a script of (status, body, delay)."""

    def __init__(self) -> None:
        self.script: list[tuple[int, dict | str, float]] = []
        self.requests: list[dict] = []
        self.headers: list[dict] = []
        server = self

        class Handler(BaseHTTPRequestHandler):
            def log_message(self, *args) -> None:
                pass

            def do_POST(self) -> None:
                length = int(self.headers.get("content-length", 0))
                server.requests.append(json.loads(self.rfile.read(length)))
                server.headers.append(dict(self.headers))
                status, body, delay = server.script.pop(0) if server.script else (500, "empty", 0)
                time.sleep(delay)
                data = (json.dumps(body) if isinstance(body, dict) else body).encode()
                try:
                    self.send_response(status)
                    if status == 429:
                        self.send_header("Retry-After", "0")
                    self.send_header("content-type", "application/json")
                    self.send_header("content-length", str(len(data)))
                    self.end_headers()
                    self.wfile.write(data)
                except (BrokenPipeError, ConnectionResetError):
                    pass

        self.httpd = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.url = f"http://127.0.0.1:{self.httpd.server_address[1]}/v1"
        self.thread = threading.Thread(target=self.httpd.serve_forever, daemon=True)
        self.thread.start()

    def close(self) -> None:
        self.httpd.shutdown()
        self.httpd.server_close()


def chat(content: str, prompt_tokens: int = 12, completion_tokens: int = 5) -> dict:
    return {"id": "x", "object": "chat.completion", "model": "m",
            "choices": [{"index": 0, "message": {"role": "assistant", "content": content},
                         "finish_reason": "stop"}],
            "usage": {"prompt_tokens": prompt_tokens, "completion_tokens": completion_tokens}}


@pytest.fixture
def server() -> Iterator[ChatServer]:
    s = ChatServer()
    yield s
    s.close()


def _provider(server: ChatServer, **kw) -> OpenAIProvider:
    return OpenAIProvider("test-model", base_url=server.url, api_key="sk-test-secret",
                          base_delay=0.01, **kw)


def test_success_sends_schema_and_key_and_counts_tokens(server: ChatServer) -> None:
    server.script = [(200, chat('{"causes": ["debris"]}', 40, 7), 0)]
    llm = LLM(_provider(server))
    assert llm.structured("why?", Causes).causes == ["debris"]
    req = server.requests[0]
    assert req["model"] == "test-model" and req["temperature"] == 0.0
    assert req["response_format"]["type"] == "json_schema"
    assert req["response_format"]["json_schema"]["schema"]["properties"]["causes"]["type"] == "array"
    assert server.headers[0]["Authorization"] == "Bearer sk-test-secret"
    assert (llm.stats.total.input_tokens, llm.stats.total.output_tokens) == (40, 7)


@pytest.mark.parametrize("first", [429, 500, 503])
def test_retryable_status_then_success(server: ChatServer, first: int) -> None:
    server.script = [(first, {"error": "busy"}, 0), (200, chat('{"causes": ["a"]}'), 0)]
    assert LLM(_provider(server)).structured("q", Causes).causes == ["a"]
    assert len(server.requests) == 2


def test_timeout_is_retried_then_reported(server: ChatServer) -> None:
    server.script = [(200, chat('{"causes": []}'), 1.0)] * 2
    prov = _provider(server, timeout=0.2, attempts=2)
    with pytest.raises(ProviderUnreachableError, match="failed after 2 attempts: timeout"):
        LLM(prov).structured("q", Causes)


def test_unreachable_base_url_is_reported() -> None:
    prov = OpenAIProvider("m", base_url="http://127.0.0.1:9/v1", attempts=2, base_delay=0.01)
    with pytest.raises(ProviderUnreachableError, match="cannot reach http://127.0.0.1:9/v1"):
        LLM(prov).structured("q", Causes)


def test_client_error_is_not_retried(server: ChatServer) -> None:
    server.script = [(400, {"error": {"message": "bad model"}}, 0)]
    with pytest.raises(ProviderResponseError, match="HTTP 400"):
        LLM(_provider(server)).structured("q", Causes)
    assert len(server.requests) == 1


def test_rejected_key_says_which_variable(server: ChatServer) -> None:
    server.script = [(401, {"error": "no"}, 0)]
    with pytest.raises(MissingAPIKeyError, match="OPENAI_API_KEY"):
        LLM(_provider(server)).structured("q", Causes)


def test_missing_openai_key_says_how_to_set_it(monkeypatch: pytest.MonkeyPatch) -> None:
    for var in ("OPENAI_API_KEY", "OPENAI_BASE_URL", "REGEN_OPENAI_BASE_URL"):
        monkeypatch.delenv(var, raising=False)
    with pytest.raises(MissingAPIKeyError, match="export OPENAI_API_KEY"):
        LLM("openai:gpt-4o-mini")


def test_missing_anthropic_key_says_how_to_set_it(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("ANTHROPIC_API_KEY", raising=False)
    with pytest.raises(MissingAPIKeyError, match="export ANTHROPIC_API_KEY"):
        LLM("anthropic:claude-sonnet-4-5")


def test_key_is_not_in_the_cache(server: ChatServer, tmp_path) -> None:
    server.script = [(200, chat('{"causes": ["a"]}'), 0)]
    cache = tmp_path / "c.sqlite"
    LLM(_provider(server), cache=cache).structured("q", Causes)
    for f in tmp_path.iterdir():
        assert b"sk-test-secret" not in f.read_bytes()


def test_anthropic_tool_answer(server: ChatServer) -> None:
    server.script = [(200, {"content": [{"type": "tool_use", "name": "answer",
                                         "input": {"causes": ["ambulance"]}}],
                            "usage": {"input_tokens": 9, "output_tokens": 3}}, 0)]
    prov = AnthropicProvider("claude-test", api_key="k", base_url=server.url + "/messages",
                             base_delay=0.01)
    llm = LLM(prov)
    assert llm.structured([{"role": "system", "content": "be brief"}, {"role": "user", "content": "q"}],
                          Causes).causes == ["ambulance"]
    req = server.requests[0]
    assert req["system"] == "be brief" and req["tool_choice"] == {"type": "tool", "name": "answer"}
    assert server.headers[0]["x-api-key"] == "k"
