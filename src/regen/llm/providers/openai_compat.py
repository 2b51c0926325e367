"""OpenAI chat completions, and any server that speaks the same protocol (vLLM, Ollama,
llama.cpp server, LM Studio) through a base URL."""

from __future__ import annotations

import base64
import os
from typing import Any

import httpx

from regen.errors import MissingAPIKeyError, ProviderResponseError
from regen.llm.base import Completion, Message, Provider, Sampling, images_of, with_retries
from regen.llm.providers.http import post_json, request_timeout, snippet, token_count
from regen.llm.providers.keys import is_official, pick_key

DEFAULT_BASE_URL = "https://api.openai.com/v1"
OFFICIAL_KEY_VAR = "OPENAI_API_KEY"  # sent only to DEFAULT_BASE_URL's host
CUSTOM_KEY_VAR = "REGEN_OPENAI_API_KEY"  # sent only to a custom base URL


def wire_message(message: Message) -> dict[str, Any]:
    """``message`` as chat completions take it: a text-only one as it is; one with images as
    content parts, its text first, then each PNG as a base64 data URL."""
    images = images_of(message)
    wire: dict[str, Any] = {k: v for k, v in message.items() if k != "images"}
    if images:
        text = [{"type": "text", "text": message["content"]}] if message["content"] else []
        wire["content"] = text + [
            {"type": "image_url",
             "image_url": {"url": "data:image/png;base64," + base64.b64encode(png).decode("ascii")}}
            for png in images]
    return wire


class OpenAIProvider(Provider):
    """``openai:<model>``. Base URL from the argument, ``REGEN_OPENAI_BASE_URL`` or
    ``OPENAI_BASE_URL`` (default: OpenAI's own API).

    Keys go only to the service they belong to: OpenAI's API gets ``OPENAI_API_KEY`` (required);
    any other base URL gets ``REGEN_OPENAI_API_KEY``, or no Authorization header when that is
    unset (local servers need none). An explicit ``api_key`` is sent wherever the URL points.

    ``schema_mode``: 'json_schema' (structured outputs), 'json_object' (JSON mode, the schema
    goes into the prompt) or 'none' (schema in the prompt only), for servers that lack one.

    ``timeout`` [s] per request: the argument, else ``REGEN_LLM_TIMEOUT``, else 120; a request
    that times out is tried ``attempts`` times in all.

    Images (``Message["images"]``) go as ``image_url`` content parts; the model behind the
    URL must be able to read them (a text-only server refuses the request).
    """

    name = "openai"
    accepts_images = True

    def __init__(self, model: str, *, base_url: str | None = None, api_key: str | None = None,
                 timeout: float | None = None, attempts: int = 4, schema_mode: str = "json_schema",
                 base_delay: float = 0.5):
        if not model:
            raise ProviderResponseError("name the model: openai:<model>, e.g. openai:gpt-4o-mini")
        self.model = model
        self.base_url = (base_url or os.environ.get("REGEN_OPENAI_BASE_URL")
                         or os.environ.get("OPENAI_BASE_URL") or DEFAULT_BASE_URL).rstrip("/")
        self.official = is_official(self.base_url, DEFAULT_BASE_URL)
        key = pick_key(api_key, self.base_url, official=DEFAULT_BASE_URL,
                       official_var=OFFICIAL_KEY_VAR, custom_var=CUSTOM_KEY_VAR)
        if key.value is None and self.official:
            raise MissingAPIKeyError(
                f"openai: no API key. Set it in the environment: export {OFFICIAL_KEY_VAR}=sk-... "
                "(or point REGEN_OPENAI_BASE_URL at an OpenAI-compatible server, or use --llm local)")
        self._key = key
        self.timeout = request_timeout(timeout)
        self.attempts = attempts
        self.base_delay = base_delay
        self.schema_mode = schema_mode
        self._client = httpx.Client(timeout=self.timeout)

    def _body(self, messages: list[Message], schema: dict[str, Any] | None,
              sampling: Sampling) -> dict[str, Any]:
        wire = [wire_message(m) for m in messages]
        body: dict[str, Any] = {"model": self.model, "messages": wire,
                                "temperature": sampling.temperature,
                                "max_tokens": sampling.max_tokens, "seed": sampling.seed}
        if sampling.top_p is not None:
            body["top_p"] = sampling.top_p
        if schema is not None:
            if self.schema_mode == "json_schema":
                body["response_format"] = {"type": "json_schema", "json_schema": {
                    "name": str(schema.get("title", "answer"))[:64], "schema": schema}}
            else:
                import json

                hint = "Answer with one JSON object following this JSON schema:\n" + json.dumps(schema)
                body["messages"] = [{"role": "system", "content": hint}, *wire]
                if self.schema_mode == "json_object":
                    body["response_format"] = {"type": "json_object"}
        return body

    def complete(self, messages: list[Message], *, schema: dict[str, Any] | None,
                 sampling: Sampling) -> Completion:
        self.check_images(messages)
        url = f"{self.base_url}/chat/completions"
        headers = {"Authorization": f"Bearer {self._key.value}"} if self._key.value else {}
        body = self._body(messages, schema, sampling)

        def once() -> Completion:
            raw, data = post_json(self._client, url, body, headers, who=self.base_url,
                                  timeout=self.timeout, refused=self._refused)
            try:
                text = data["choices"][0]["message"]["content"] or ""
                if not isinstance(text, str):
                    raise TypeError("content is not text")
            except (KeyError, IndexError, TypeError):
                raise ProviderResponseError(f"{self.base_url} sent a reply that is not a chat "
                                            f"completion: {snippet(raw)}") from None
            usage = data.get("usage")
            return Completion(text=text, input_tokens=token_count(usage, "prompt_tokens"),
                              output_tokens=token_count(usage, "completion_tokens"))

        return with_retries(once, what=f"{self.id} call", attempts=self.attempts,
                            base_delay=self.base_delay)

    def _refused(self, status: int) -> str:
        if self._key.value:
            return (f"{self.base_url} refused the API key (HTTP {status}); check "
                    f"{self._key.source}")
        return (f"{self.base_url} refused the request without an API key (HTTP {status}). If "
                f"this server needs one, export {CUSTOM_KEY_VAR}=... ({OFFICIAL_KEY_VAR} is "
                f"only sent to {DEFAULT_BASE_URL})")
