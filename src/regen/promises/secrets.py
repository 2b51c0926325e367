"""A provider's error redacted of every secret the request carried, before it is printed, logged
or stored.

A model service, or a proxy in front of it, may echo the request in an error body: its headers
(``Authorization: Bearer sk-...``, ``x-api-key``), its URL (``?api-key=...``) or all of it. That
body becomes the error's message, which lands on the terminal, in the log, in ``run.json`` and in
the report. So the message is redacted where it is made (:func:`redact`, called by the HTTP
exchange with the request's headers and URL), and again wherever an error leaves the toolkit.

What counts as a secret:

- every header value the request carried but those of :data:`PUBLIC_HEADERS` (content type,
  protocol version ...), and the token of an ``Authorization`` value (``Bearer <token>``);
- every query parameter value and the user and password of the request's URL;
- every key a provider picked (:func:`remember`: the process keeps them, so that an error made
  anywhere, by anyone, is redacted of them too).

A value shorter than :data:`MIN_SECRET` characters is no secret (redacting it would garble
words). A secret is replaced wherever it appears: as it is, JSON-escaped, URL-encoded, HTML-escaped,
and every piece of it of :data:`MIN_FRAGMENT` or more characters (a key cut by a message's length
limit, or split across lines or JSON strings). Whatever the known secrets, the value of anything
that looks like a credential (``Authorization: ...``, ``"x-api-key": "..."``, ``api_key=...``,
``Bearer <token>``) is replaced too.
"""

from __future__ import annotations

import html
import json
import logging
import re
import threading
from collections.abc import Iterable, Mapping
from urllib.parse import parse_qsl, quote, quote_plus, urlsplit

REDACTED = "[redacted]"
MIN_SECRET = 6  # shorter values are not secrets [characters]
MIN_FRAGMENT = 8  # shortest piece of a secret recognized on its own [characters]
#: Headers whose values are no secret (compared in lower case).
PUBLIC_HEADERS = frozenset({"accept", "accept-encoding", "anthropic-beta", "anthropic-version", "connection",
                            "content-length", "content-type", "host", "openai-beta", "user-agent"})

_NAME = r"(?:authorization|api[-_]?key|access[-_]?token|client[-_]?secret)"
# a credential's name, its separator (quoted or not, JSON-escaped or not), then its value
_PAIR = re.compile(rf"(?i)({_NAME}\\?[\"']?\s*[:=]\s*\\?[\"']?)((?:[a-z]+[ \t]+)?[^\s\"'\\,;&}}]+)")
_BEARER = re.compile(r"(?i)\b(bearer\s+)([A-Za-z0-9._~+/=-]{6,})")

_known: set[str] = set()
_lock = threading.Lock()


def _usable(value: str | None) -> str | None:
    value = (value or "").strip()
    return value if len(value) >= MIN_SECRET else None


def secrets_of(headers: Mapping[str, str] | None = None, url: str = "",
               extra: Iterable[str | None] = ()) -> list[str]:
    """The secrets a request carried (see the module docstring), longest first."""
    found: set[str] = set()
    for name, value in (headers or {}).items():
        if str(name).lower() in PUBLIC_HEADERS or not isinstance(value, str):
            continue
        found.add(value)
        scheme, _, token = value.strip().partition(" ")
        if token and scheme.isalpha():  # 'Bearer <token>', 'Basic <base64>'
            found.add(token)
    if url:
        try:
            parts = urlsplit(url)
            found.update(v for _, v in parse_qsl(parts.query, keep_blank_values=False))
            found.update(v for v in (parts.username, parts.password) if v)
        except ValueError:  # not a URL: nothing in it is known to be a secret
            pass
    found.update(v for v in extra if v)
    usable = {s for v in found if (s := _usable(v)) is not None}
    return sorted(usable, key=len, reverse=True)


def remember(*secrets: str | None) -> None:
    """Keep ``secrets`` for the life of the process: every later :func:`redact` removes them."""
    usable = {s for v in secrets if (s := _usable(v)) is not None}
    with _lock:
        _known.update(usable)


def _variants(secret: str) -> set[str]:
    """How ``secret`` may be written in a body that echoes it."""
    return {secret, json.dumps(secret)[1:-1], json.dumps(secret, ensure_ascii=False)[1:-1],
            secret.replace("/", "\\/"), quote(secret, safe=""), quote(secret), quote_plus(secret),
            html.escape(secret)} - {""}


def _fragments(text: str, secret: str) -> str:
    """``text`` with every run of :data:`MIN_FRAGMENT` or more characters that is a piece of
    ``secret`` replaced."""
    k = MIN_FRAGMENT
    if len(secret) < k or len(text) < k:
        return text
    pieces = {secret[i:i + k] for i in range(len(secret) - k + 1)}
    spans: list[list[int]] = []
    for i in range(len(text) - k + 1):
        if text[i:i + k] in pieces:
            if spans and i <= spans[-1][1]:
                spans[-1][1] = i + k
            else:
                spans.append([i, i + k])
    if not spans:
        return text
    out, last = [], 0
    for start, end in spans:
        out += [text[last:start], REDACTED]
        last = end
    out.append(text[last:])
    return "".join(out)


def redact(text: str, secrets: Iterable[str] = (), *, credentials: bool = True) -> str:
    """``text`` without ``secrets`` (:func:`secrets_of`) and the secrets :func:`remember` kept;
    with ``credentials``, without the value of anything that looks like a credential either (for
    text a server wrote; the toolkit's own messages, which name variables such as
    ``OPENAI_API_KEY=sk-...`` in their advice, pass False). Cost: linear in ``len(text)`` per
    secret."""
    with _lock:
        known = set(_known)
    every = sorted({s for v in secrets if (s := _usable(v)) is not None} | known, key=len, reverse=True)
    for secret in every:
        for form in sorted(_variants(secret), key=len, reverse=True):
            text = text.replace(form, REDACTED)
        text = _fragments(text, secret)
    if not credentials:
        return text
    text = _PAIR.sub(lambda m: m.group(1) + REDACTED, text)
    return _BEARER.sub(lambda m: m.group(1) + REDACTED, text)


class RedactingFilter(logging.Filter):
    """A logging filter that redacts every record of the secrets :func:`remember` kept (a
    library's own log line, e.g. a request's URL, may carry one). Installed on the handlers of
    the ``regen`` command's log."""

    def filter(self, record: logging.LogRecord) -> bool:
        message = record.getMessage()
        clean = redact(message, credentials=False)
        if clean != message:
            record.msg, record.args = clean, None
        return True


__all__ = ["MIN_FRAGMENT", "MIN_SECRET", "PUBLIC_HEADERS", "REDACTED", "RedactingFilter", "redact", "remember",
           "secrets_of"]
