"""A provider's error redacted of every secret the request carried, however it is echoed."""

from __future__ import annotations

import base64
import json
from urllib.parse import quote, quote_plus

import pytest

from regen.promises.secrets import REDACTED, redact, remember, secrets_of

KEY = "sk-test-4f9Q2mZx7LkP0aB3cD5eF6gH"
HEADERS = {"Authorization": f"Bearer {KEY}", "Content-Type": "application/json",
           "anthropic-version": "2023-06-01"}


def _gone(text: str) -> None:
    assert KEY not in text
    for k in range(0, len(KEY) - 8):  # no piece of 9 characters or more either
        assert KEY[k:k + 9] not in text, (KEY[k:k + 9], text)


@pytest.mark.parametrize("echo", [
    json.dumps({"error": "bad request", "headers": HEADERS}),  # the headers as JSON
    json.dumps({"error": "bad request", "headers": HEADERS}, indent=2),
    f"POST /v1/chat/completions\r\nAuthorization: Bearer {KEY}\r\nHost: 127.0.0.1\r\n",  # a header dump
    f"invalid key {KEY[:20]}",  # cut by the server
    f"key: '{KEY[:16]}' + '{KEY[16:]}'",  # split in two strings
    f"key={quote(KEY, safe='')}", f"key={quote_plus(KEY)}",  # URL-encoded
    json.dumps({"echo": json.dumps({"auth": f"Bearer {KEY}"})}),  # JSON inside JSON
    f"<p>{KEY}</p>",
])
def test_the_key_is_redacted_however_it_is_echoed(echo: str) -> None:
    out = redact(echo, secrets_of(HEADERS))
    _gone(out)
    assert REDACTED in out


def test_what_is_not_secret_stays() -> None:
    out = redact(json.dumps({"error": {"message": "model 'm' not found", "type": "invalid_request"},
                             "headers": HEADERS}), secrets_of(HEADERS))
    assert "model 'm' not found" in out and "application/json" in out and "2023-06-01" in out


def test_the_secrets_of_a_request() -> None:
    got = secrets_of({"x-api-key": "k-123456789", "Authorization": "Basic dXNlcjpwYXNzd29yZA==",
                      "content-type": "application/json", "x-short": "abc"},
                     "https://user:hunter2hunter2@proxy.example/v1?api-key=q-987654321&x=1")
    assert {"k-123456789", "dXNlcjpwYXNzd29yZA==", "Basic dXNlcjpwYXNzd29yZA==", "q-987654321",
            "hunter2hunter2"} <= set(got)
    assert "application/json" not in got and "abc" not in got  # public, and too short to be one
    assert got == sorted(got, key=len, reverse=True)


@pytest.mark.parametrize("text", [
    '{"x-api-key": "whatever-it-is-123"}',
    "Authorization: Basic d2hvOmtub3dz",
    "GET /v1/models?api_key=abcdef123456&limit=1",
    "bearer abcdefghijklmnop",
])
def test_anything_that_looks_like_a_credential_is_redacted_unknown(text: str) -> None:
    out = redact(text)
    assert REDACTED in out
    for value in ("whatever-it-is-123", "d2hvOmtub3dz", "abcdef123456", "abcdefghijklmnop"):
        assert value not in out


def test_the_toolkits_own_advice_keeps_its_words() -> None:
    advice = "no API key. Set it in the environment: export OPENAI_API_KEY=sk-... (or use --llm local)"
    assert redact(advice, credentials=False) == advice


def test_a_remembered_key_is_redacted_everywhere_later() -> None:
    key = base64.b64encode(b"remembered-only-key").decode()
    remember(key, None, "")
    assert key not in redact(f"some error mentioning {key} in passing", credentials=False)


def test_a_log_line_carrying_a_remembered_key_is_redacted() -> None:
    import logging

    from regen.promises.secrets import RedactingFilter

    key = "log-only-key-5b7c9d1e3f"
    remember(key)
    record = logging.LogRecord("httpx", logging.INFO, __file__, 1, "HTTP Request: POST %s", (f"http://h/?k={key}",),
                               None)
    assert RedactingFilter().filter(record)
    assert key not in record.getMessage() and REDACTED in record.getMessage()
