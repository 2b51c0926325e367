"""Which API key a provider may send where.

A vendor's key (``OPENAI_API_KEY``, ``ANTHROPIC_API_KEY``) goes only to that vendor's own
endpoint. A custom base URL (a local vLLM or Ollama server, a proxy, anything else) is another
service: it gets its own variable (``REGEN_OPENAI_API_KEY``, ``REGEN_ANTHROPIC_API_KEY``) or no
key at all, so pointing the toolkit at a server never hands that server the vendor key.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import httpx

from regen.promises.secrets import remember


def _origin(url: str) -> tuple[str, str, int | None] | None:
    try:
        u = httpx.URL(url)
    except (httpx.InvalidURL, TypeError):
        return None
    port = u.port or {"https": 443, "http": 80}.get(u.scheme)
    return (u.scheme, u.host, port)


def is_official(url: str, official: str) -> bool:
    """Whether ``url`` points at the same service as ``official`` (same scheme, host and port).

    The path is not compared: a key belongs to a host, and a wrong path on the vendor's own host
    should fail with the vendor's error, not by silently dropping the key."""
    mine = _origin(url)
    return mine is not None and mine == _origin(official)


@dataclass(frozen=True)
class Key:
    value: str | None  # None: send no key
    source: str  # where it came from, for error messages ('' when there is none)


def pick_key(explicit: str | None, url: str, *, official: str, official_var: str,
             custom_var: str) -> Key:
    """The key for a call to ``url``: the explicit argument if given (the caller chose both), else
    ``official_var`` for the official endpoint, else ``custom_var`` (or none) for any other URL.
    The key is remembered as a secret: every error message is redacted of it."""
    if explicit:
        remember(explicit)  # never printed, logged or stored (regen.promises.secrets)
        return Key(explicit, "the api_key argument")
    var = official_var if is_official(url, official) else custom_var
    value = os.environ.get(var) or None
    remember(value)
    return Key(value, var if value else "")
