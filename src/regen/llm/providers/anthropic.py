"""Anthropic's Messages API; structured answers through a forced tool call."""

from __future__ import annotations

import base64
import json
import os
from typing import Any

import httpx

from regen.errors import MissingAPIKeyError, ProviderResponseError
from regen.llm.base import Completion, Message, Provider, Sampling, images_of, with_retries
from regen.llm.providers.http import post_json, request_timeout, snippet, token_count
from regen.llm.providers.keys import is_official, pick_key

API_URL = "https://api.anthropic.com/v1/messages"
OFFICIAL_KEY_VAR = "ANTHROPIC_API_KEY"  # sent only to API_URL's host
CUSTOM_KEY_VAR = "REGEN_ANTHROPIC_API_KEY"  # sent only to a custom messages URL


def wire_message(message: Message) -> dict[str, Any]:
    """``message`` as the Messages API takes it: a text-only one as it is; one with images as
    content blocks, each PNG a base64 ``image`` block, then the text (images before the text,
    as Anthropic advises)."""
    images = images_of(message)
    wire: dict[str, Any] = {k: v for k, v in message.items() if k != "images"}
    if images:
        blocks: list[dict[str, Any]] = [
            {"type": "image", "source": {"type": "base64", "media_type": "image/png",
                                         "data": base64.b64encode(png).decode("ascii")}}
            for png in images]
        if message["content"]:
            blocks.append({"type": "text", "text": message["content"]})
        wire["content"] = blocks
    return wire


class AnthropicProvider(Provider):
    """``anthropic:<model>``. Messages URL from ``base_url`` or ``REGEN_ANTHROPIC_BASE_URL``
    (the full URL of the messages endpoint; default: Anthropic's own API).

    Keys go only to the service they belong to: Anthropic's API gets ``ANTHROPIC_API_KEY``
    (required); any other URL gets ``REGEN_ANTHROPIC_API_KEY``, or no ``x-api-key`` header when
    that is unset. An explicit ``api_key`` is sent wherever the URL points.

    ``timeout`` [s] per request: the argument, else ``REGEN_LLM_TIMEOUT``, else 120; a request
    that times out is tried ``attempts`` times in all.

    Images (``Message["images"]``) go as base64 ``image`` blocks before the message's text.
    """

    name = "anthropic"
    accepts_images = True

    def __init__(self, model: str, *, api_key: str | None = None, base_url: str | None = None,
                 timeout: float | None = None, attempts: int = 4, base_delay: float = 0.5):
        if not model:
            raise ProviderResponseError("name the model: anthropic:<model>")
        self.model = model
        self.url = base_url or os.environ.get("REGEN_ANTHROPIC_BASE_URL") or API_URL
        self.official = is_official(self.url, API_URL)
        self._key = pick_key(api_key, self.url, official=API_URL,
                             official_var=OFFICIAL_KEY_VAR, custom_var=CUSTOM_KEY_VAR)
        if self._key.value is None and self.official:
            raise MissingAPIKeyError(f"anthropic: no API key. Set it in the environment: "
                                     f"export {OFFICIAL_KEY_VAR}=... (or use --llm local)")
        self.timeout = request_timeout(timeout)
        self.attempts = attempts
        self.base_delay = base_delay
        self._client = httpx.Client(timeout=self.timeout)

    def complete(self, messages: list[Message], *, schema: dict[str, Any] | None,
                 sampling: Sampling) -> Completion:
        self.check_images(messages)
        system = "\n\n".join(m["content"] for m in messages if m["role"] == "system")
        body: dict[str, Any] = {
            "model": self.model, "max_tokens": sampling.max_tokens,
            "temperature": sampling.temperature,
            "messages": [wire_message(m) for m in messages if m["role"] != "system"],
        }
        if system:
            body["system"] = system
        if schema is not None:
            body["tools"] = [{"name": "answer", "description": "Give the answer.", "input_schema": schema}]
            body["tool_choice"] = {"type": "tool", "name": "answer"}
        headers = {"anthropic-version": "2023-06-01"}
        if self._key.value:
            headers["x-api-key"] = self._key.value

        def once() -> Completion:
            raw, data = post_json(self._client, self.url, body, headers, who=self._who,
                                  timeout=self.timeout, refused=self._refused, retry_status=(429, 529))
            try:
                text = ""
                for block in data.get("content", []):
                    if block.get("type") == "tool_use":
                        text = json.dumps(block.get("input", {}))
                        break
                    if block.get("type") == "text":
                        text += block.get("text", "")
                usage = data.get("usage")
            except (ValueError, AttributeError, TypeError, RecursionError):
                raise ProviderResponseError(f"{self._who} sent a reply that is not a Messages API "
                                            f"answer: {snippet(raw)}") from None
            return Completion(text=text, input_tokens=token_count(usage, "input_tokens"),
                              output_tokens=token_count(usage, "output_tokens"))

        return with_retries(once, what=f"{self.id} call", attempts=self.attempts,
                            base_delay=self.base_delay)

    @property
    def _who(self) -> str:
        return "Anthropic" if self.official else self.url

    def _refused(self, status: int) -> str:
        if self._key.value:
            return f"{self._who} refused the API key (HTTP {status}); check {self._key.source}"
        return (f"{self.url} refused the request without an API key (HTTP {status}). If this "
                f"server needs one, export {CUSTOM_KEY_VAR}=... ({OFFICIAL_KEY_VAR} is only sent "
                f"to {API_URL})")
