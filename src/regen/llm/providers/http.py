"""One HTTP exchange with a model service, shared by the HTTP providers: what is retried, what
is the user's to fix, and what is the service's fault, each as the toolkit's own error."""

from __future__ import annotations

import json
import math
import os
import time
from collections.abc import Callable
from typing import Any

import httpx

from regen.errors import ConfigError, MissingAPIKeyError, ProviderResponseError
from regen.llm.base import RetryableError
from regen.llm.sanitize import clean_text, shorten
from regen.promises.secrets import redact, remember, secrets_of

DEFAULT_TIMEOUT = 120.0  # [s] per request, from connecting to the last byte of the reply
TIMEOUT_VAR = "REGEN_LLM_TIMEOUT"  # overrides DEFAULT_TIMEOUT; an explicit timeout wins
MAX_REPLY_BYTES = 32_000_000  # a longer reply is refused instead of read into memory
SNIPPET_CHARS = 300  # how much of a bad reply an error message quotes
_REDACTED_CHARS = 4 * SNIPPET_CHARS  # how much of it is redacted, before it is cut to SNIPPET_CHARS


def request_timeout(explicit: float | None) -> float:
    """The request timeout [s]: ``explicit``, else ``REGEN_LLM_TIMEOUT``, else 120."""
    if explicit is not None:
        value, source = explicit, "the timeout"
    elif os.environ.get(TIMEOUT_VAR):
        value, source = os.environ[TIMEOUT_VAR], TIMEOUT_VAR
    else:
        return DEFAULT_TIMEOUT
    try:
        seconds = float(value)
    except (TypeError, ValueError):
        seconds = math.nan
    if not (math.isfinite(seconds) and seconds > 0):
        raise ConfigError(f"{source} must be a positive number of seconds, not {value!r}")
    return seconds


def retry_after(resp: httpx.Response) -> float | None:
    """The server's Retry-After [s], if it sent a usable number."""
    try:
        value = float(resp.headers.get("retry-after", "nan"))
    except ValueError:
        return None
    return value if math.isfinite(value) and value >= 0 else None


def token_count(usage: Any, key: str) -> int:
    """A token count from a reply's usage block; anything but a count is 0."""
    value = usage.get(key) if isinstance(usage, dict) else None
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        return 0
    return max(0, int(value))


def snippet(text: str, secrets: list[str] | None = None) -> str:
    """Part of a server's reply for an error message, on one line without control characters,
    redacted of ``secrets`` (:func:`regen.promises.secrets.secrets_of`, the request's) and of
    anything that looks like a credential before it is cut (a cut key is still redacted)."""
    one_line = " ".join(clean_text(text).split())
    return shorten(redact(one_line[:_REDACTED_CHARS], secrets or ()), SNIPPET_CHARS)


def post_json(client: httpx.Client, url: str, body: dict[str, Any], headers: dict[str, str], *,
              who: str, timeout: float, refused: Callable[[int], str],
              retry_status: tuple[int, ...] = (429,)) -> tuple[str, Any]:
    """POST ``body``; return the reply text and its parsed JSON.

    Timeouts (``timeout`` [s] for the whole exchange), unreachable hosts, ``retry_status`` and 5xx
    raise :class:`RetryableError` (retried by the caller); 401/403 raise
    :class:`MissingAPIKeyError` with ``refused(status)``; other 4xx, a body that is not JSON and
    one longer than :data:`MAX_REPLY_BYTES` raise :class:`ProviderResponseError` naming ``who``.
    Every message is redacted of the secrets the request carried (its header values and URL
    parameters, :mod:`regen.promises.secrets`); so is the reply text returned, which callers
    quote only in messages.
    """
    secrets = secrets_of(headers, url)
    remember(*secrets)  # an error made of this request's reply anywhere later is redacted too
    try:
        text, data = _exchange(client, url, body, headers, who=who, timeout=timeout, refused=refused,
                               retry_status=retry_status, secrets=secrets)
    except (RetryableError, MissingAPIKeyError, ProviderResponseError) as exc:
        exc.args = tuple(redact(a, secrets, credentials=False) if isinstance(a, str) else a for a in exc.args)
        raise
    return redact(text[:_REDACTED_CHARS], secrets), data


def _exchange(client: httpx.Client, url: str, body: dict[str, Any], headers: dict[str, str], *,
              who: str, timeout: float, refused: Callable[[int], str], retry_status: tuple[int, ...],
              secrets: list[str]) -> tuple[str, Any]:
    deadline = time.monotonic() + timeout
    try:
        with client.stream("POST", url, json=body, headers=headers) as resp:
            status = resp.status_code
            chunks: list[bytes] = []
            size = 0
            for chunk in resp.iter_bytes():
                size += len(chunk)
                if size > MAX_REPLY_BYTES:
                    raise ProviderResponseError(f"{who} sent a reply larger than "
                                                f"{MAX_REPLY_BYTES} bytes; not read")
                if time.monotonic() > deadline:  # a reply trickling in never trips the read timeout
                    raise RetryableError(f"timeout after {timeout:g} s (reply still arriving)")
                chunks.append(chunk)
    except httpx.TimeoutException as exc:
        raise RetryableError(f"timeout after {timeout:g} s ({type(exc).__name__})") from None
    except httpx.TransportError as exc:
        raise RetryableError(f"cannot reach {who} ({type(exc).__name__}: {exc})") from None
    except (httpx.HTTPError, httpx.InvalidURL) as exc:  # a broken encoding, a bad URL
        raise ProviderResponseError(f"{who}: {type(exc).__name__}: {snippet(str(exc), secrets)}") from None
    data = b"".join(chunks)
    text = data.decode("utf-8", "replace")
    if status in retry_status or status >= 500:
        raise RetryableError(f"HTTP {status}", retry_after(resp))
    if status in (401, 403):
        raise MissingAPIKeyError(refused(status))
    if status >= 400:
        raise ProviderResponseError(f"{who} answered HTTP {status}: {snippet(text, secrets)}")
    try:
        return text, json.loads(data)
    except (ValueError, RecursionError):
        raise ProviderResponseError(f"{who} sent a reply that is not JSON: {snippet(text, secrets)}") from None
