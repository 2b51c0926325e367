"""A loopback model server that misbehaves on cue, for tests of the HTTP providers.

It listens on 127.0.0.1 only and speaks OpenAI chat completions (``POST /v1/chat/completions``)
and Anthropic messages (``POST /v1/messages``). Each request takes the next :class:`Reply` from
the script (``server.queue(...)``): an answer wrapped in the protocol's envelope, any status code
(with Retry-After), a verbatim body (not JSON, hostile JSON), a hang, or a connection reset.
Every request is recorded with its headers and body.

Everything is bounded: a hang sleeps a fixed time (longer than the client timeouts the tests
use) and then closes, the server serves at most ``max_requests`` requests and stops by itself
after ``lifetime`` seconds. Use it through the ``fault_server`` fixture (import it into the
folder's ``conftest.py``: ``from fault_server import fault_server``)::

    def test_x(fault_server):
        fault_server.queue(status(429, retry_after=0), answer('{"causes": ["rain"]}'))
        provider = OpenAIProvider("m", base_url=fault_server.openai_url, api_key="k")
"""

from __future__ import annotations

import json
import socket
import struct
import threading
from collections.abc import Iterator
from dataclasses import dataclass, field
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any

import pytest

from regen.core.base import Answer

HANG_SECONDS = 3.0  # [s] a hang lasts this long, then the connection closes without a reply
MAX_REQUESTS = 64  # requests served; later ones are reset at once (a runaway retry loop)
LIFETIME = 120.0  # [s] the server shuts itself down after this even if nobody closes it
MAX_BODY_BYTES = 10_000_000  # request bodies beyond this are not read

OPENAI_PATH = "/v1/chat/completions"
ANTHROPIC_PATH = "/v1/messages"


@dataclass
class Reply:
    """What the server does with one request.

    ``content`` is the model's answer text, wrapped in the envelope of the protocol that was
    asked (a chat completion, or a Messages reply whose answer is a ``tool_use`` block when the
    text is a JSON object and a ``text`` block otherwise). ``body`` replaces the whole body
    verbatim (a str or bytes as is, anything else as JSON).
    """

    status: int = 200
    content: str | None = None
    body: Any = None
    headers: dict[str, str] = field(default_factory=dict)
    retry_after: str | None = None
    usage: tuple[int, int] = (12, 5)  # (input, output) tokens reported
    delay: float = 0.0  # [s] before the reply is sent
    hang: float | None = None  # [s] sleep, then close the connection without a reply
    reset: bool = False  # close the connection with a TCP reset instead of replying


@dataclass
class Recorded:
    """One request the server received."""

    method: str
    path: str
    header_items: list[tuple[str, str]]  # every header line as sent, repeats kept
    raw: bytes

    @property
    def headers(self) -> dict[str, str]:
        """Headers by lower-cased name (the last one wins)."""
        return {k.lower(): v for k, v in self.header_items}

    @property
    def body(self) -> Any:
        """The body parsed as JSON (None if it is not JSON)."""
        try:
            return json.loads(self.raw)
        except ValueError:
            return None


# --- replies ---------------------------------------------------------------------------------


def answer(content: str, *, usage: tuple[int, int] = (12, 5), delay: float = 0.0) -> Reply:
    """A 200 reply carrying ``content`` as the model's answer."""
    return Reply(content=content, usage=usage, delay=delay)


def status(code: int, *, retry_after: float | str | None = None, body: Any = None) -> Reply:
    """An error status, optionally with Retry-After [s, or any header text]."""
    return Reply(status=code, body={"error": {"message": f"HTTP {code}"}} if body is None else body,
                 retry_after=None if retry_after is None else str(retry_after))


def raw(body: str | bytes, *, code: int = 200, content_type: str = "application/json") -> Reply:
    """A body sent verbatim (not JSON, truncated JSON, JSON of the wrong shape)."""
    return Reply(status=code, body=body, headers={"content-type": content_type})


def hang(seconds: float = HANG_SECONDS) -> Reply:
    """Read the request, say nothing for ``seconds``, then close the connection."""
    return Reply(hang=seconds)


def reset() -> Reply:
    """Read the request, then reset the connection."""
    return Reply(reset=True)


# model answers that break things downstream of the HTTP exchange
LONE_SURROGATE = "A pedestrian \ud800 crosses the road"  # decoded: one unpaired surrogate


def deep(levels: int = 100_000) -> str:
    """An answer nested ``levels`` deep."""
    return "[" * levels


class _Decision(Answer):
    candidate: str
    plausible: bool
    reason: str = ""


class EdgeJudgement(Answer):
    """A nested answer (a list of objects with free text), as model answers often are; the shape
    :func:`huge_reason` writes."""

    decisions: list[_Decision] = []


def huge_reason(chars: int = 2_000_000) -> str:
    """An edge judgement whose reason is ``chars`` long."""
    return json.dumps({"decisions": [{"candidate": "rain", "plausible": True, "reason": "x" * chars}]})


# --- envelopes -------------------------------------------------------------------------------


def chat_completion(content: str, usage: tuple[int, int] = (12, 5)) -> dict[str, Any]:
    return {"id": "fault", "object": "chat.completion", "model": "m",
            "choices": [{"index": 0, "message": {"role": "assistant", "content": content},
                         "finish_reason": "stop"}],
            "usage": {"prompt_tokens": usage[0], "completion_tokens": usage[1]}}


def messages_reply(content: str, usage: tuple[int, int] = (12, 5)) -> dict[str, Any]:
    try:
        value = json.loads(content)
    except (ValueError, RecursionError):
        value = None
    block = ({"type": "tool_use", "id": "t", "name": "answer", "input": value}
             if isinstance(value, dict) else {"type": "text", "text": content})
    return {"id": "fault", "type": "message", "role": "assistant", "content": [block],
            "stop_reason": "end_turn", "usage": {"input_tokens": usage[0], "output_tokens": usage[1]}}


# --- the server ------------------------------------------------------------------------------


class FaultServer:
    """The server; ``openai_url`` and ``anthropic_url`` are what the providers are pointed at."""

    def __init__(self, *, max_requests: int = MAX_REQUESTS, lifetime: float = LIFETIME) -> None:
        self.script: list[Reply] = []
        self.requests: list[Recorded] = []
        self.max_requests = max_requests
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._closed = False
        server = self

        class Handler(BaseHTTPRequestHandler):
            def log_message(self, *args: Any) -> None:
                pass

            def do_POST(self) -> None:
                server._serve(self)

        self.httpd = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.httpd.daemon_threads = True
        self.httpd.block_on_close = False
        base = f"http://127.0.0.1:{self.httpd.server_address[1]}"
        self.openai_url = base + "/v1"
        self.anthropic_url = base + ANTHROPIC_PATH
        self._thread = threading.Thread(target=self.httpd.serve_forever, kwargs={"poll_interval": 0.05},
                                        daemon=True, name="fault-server")
        self._thread.start()
        self._timer = threading.Timer(lifetime, self.close)
        self._timer.daemon = True
        self._timer.start()

    def queue(self, *replies: Reply) -> FaultServer:
        with self._lock:
            self.script.extend(replies)
        return self

    @property
    def bodies(self) -> list[Any]:
        return [r.body for r in self.requests]

    def _serve(self, h: BaseHTTPRequestHandler) -> None:
        try:
            length = min(int(h.headers.get("content-length") or 0), MAX_BODY_BYTES)
        except ValueError:
            length = 0
        data = h.rfile.read(length) if length > 0 else b""
        with self._lock:
            self.requests.append(Recorded(h.command, h.path, list(h.headers.items()), data))
            over = len(self.requests) > self.max_requests or self._stop.is_set()
            reply = self.script.pop(0) if self.script and not over else None
        if over:
            return self._reset(h)
        if reply is None:
            reply = status(500, body="no reply scripted")
        if reply.reset:
            return self._reset(h)
        if reply.hang is not None:
            self._stop.wait(reply.hang)
            h.close_connection = True
            return None
        if reply.delay:
            self._stop.wait(reply.delay)
        self._send(h, reply)
        return None

    @staticmethod
    def _reset(h: BaseHTTPRequestHandler) -> None:
        # SO_LINGER with a zero timeout makes close() send RST instead of FIN
        h.connection.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
        h.close_connection = True
        h.connection.close()

    @staticmethod
    def _send(h: BaseHTTPRequestHandler, reply: Reply) -> None:
        if reply.body is not None:
            body = reply.body
        elif reply.content is not None:
            envelope = messages_reply if h.path.rstrip("/") == ANTHROPIC_PATH else chat_completion
            body = envelope(reply.content, reply.usage)
        else:
            body = {}
        if isinstance(body, str):
            # verbatim text; a lone surrogate in it goes out as the bytes a lax encoder writes
            data = body.encode("utf-8", "surrogatepass")
        elif isinstance(body, bytes):
            data = body
        else:
            data = json.dumps(body).encode()  # ASCII: lone surrogates become \\udXXX escapes
        headers = {"content-type": "application/json", **reply.headers}
        if reply.retry_after is not None:
            headers["retry-after"] = reply.retry_after
        try:
            h.send_response(reply.status)
            for k, v in headers.items():
                h.send_header(k, v)
            h.send_header("content-length", str(len(data)))
            h.end_headers()
            h.wfile.write(data)
        except OSError:
            pass  # the client gave up (timed out) first

    def close(self) -> None:
        """Stop serving (idempotent); a hanging request ends at once."""
        with self._lock:
            if self._closed:
                return
            self._closed = True
        self._stop.set()
        self._timer.cancel()
        self.httpd.shutdown()
        self.httpd.server_close()

    def __enter__(self) -> FaultServer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


@pytest.fixture
def fault_server() -> Iterator[FaultServer]:
    """A fresh :class:`FaultServer` for one test, closed afterwards."""
    with FaultServer() as server:
        yield server
