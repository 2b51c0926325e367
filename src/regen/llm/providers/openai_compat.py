"""OpenAI chat completions, and any server that speaks the same protocol (vLLM, Ollama,
llama.cpp server, LM Studio) through a base URL."""

from __future__ import annotations

import os
from typing import Any

import httpx

from regen.errors import MissingAPIKeyError, ProviderResponseError
from regen.llm.base import Completion, Message, Provider, RetryableError, Sampling, with_retries

DEFAULT_BASE_URL = "https://api.openai.com/v1"


def _retry_after(resp: httpx.Response) -> float | None:
    value = resp.headers.get("retry-after")
    try:
        return float(value) if value is not None else None
    except ValueError:
        return None


class OpenAIProvider(Provider):
    """``openai:<model>``. Key from ``OPENAI_API_KEY``; base URL from the argument,
    ``REGEN_OPENAI_BASE_URL`` or ``OPENAI_BASE_URL``. A custom base URL may run without a key.

    ``schema_mode``: 'json_schema' (structured outputs), 'json_object' (JSON mode, the schema
    goes into the prompt) or 'none' (schema in the prompt only), for servers that lack one.
    """

    name = "openai"

    def __init__(self, model: str, *, base_url: str | None = None, api_key: str | None = None,
                 timeout: float = 120.0, attempts: int = 4, schema_mode: str = "json_schema",
                 base_delay: float = 0.5):
        if not model:
            raise ProviderResponseError("name the model: openai:<model>, e.g. openai:gpt-4o-mini")
        self.model = model
        self.base_url = (base_url or os.environ.get("REGEN_OPENAI_BASE_URL")
                         or os.environ.get("OPENAI_BASE_URL") or DEFAULT_BASE_URL).rstrip("/")
        key = api_key or os.environ.get("OPENAI_API_KEY")
        if not key and self.base_url == DEFAULT_BASE_URL:
            raise MissingAPIKeyError(
                "openai: no API key. Set it in the environment: export OPENAI_API_KEY=sk-... "
                "(or point REGEN_OPENAI_BASE_URL at an OpenAI-compatible server, or use --llm local)")
        self._key = key
        self.timeout = timeout
        self.attempts = attempts
        self.base_delay = base_delay
        self.schema_mode = schema_mode
        self._client = httpx.Client(timeout=timeout)

    def _body(self, messages: list[Message], schema: dict[str, Any] | None,
              sampling: Sampling) -> dict[str, Any]:
        body: dict[str, Any] = {"model": self.model, "messages": messages,
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
                body["messages"] = [{"role": "system", "content": hint}, *messages]
                if self.schema_mode == "json_object":
                    body["response_format"] = {"type": "json_object"}
        return body

    def complete(self, messages: list[Message], *, schema: dict[str, Any] | None,
                 sampling: Sampling) -> Completion:
        url = f"{self.base_url}/chat/completions"
        headers = {"Authorization": f"Bearer {self._key}"} if self._key else {}
        body = self._body(messages, schema, sampling)

        def once() -> Completion:
            try:
                resp = self._client.post(url, json=body, headers=headers)
            except httpx.TimeoutException as exc:
                raise RetryableError(f"timeout after {self.timeout:.0f} s ({type(exc).__name__})") from None
            except httpx.TransportError as exc:
                raise RetryableError(f"cannot reach {self.base_url} ({type(exc).__name__}: {exc})") from None
            if resp.status_code == 429 or resp.status_code >= 500:
                raise RetryableError(f"HTTP {resp.status_code}", _retry_after(resp))
            if resp.status_code in (401, 403):
                raise MissingAPIKeyError(f"{self.base_url} refused the API key (HTTP "
                                         f"{resp.status_code}); check OPENAI_API_KEY")
            if resp.status_code >= 400:
                raise ProviderResponseError(f"{self.base_url} answered HTTP {resp.status_code}: "
                                            f"{resp.text[:300]}")
            try:
                data = resp.json()
                text = data["choices"][0]["message"]["content"] or ""
            except (ValueError, KeyError, IndexError, TypeError):
                raise ProviderResponseError(f"{self.base_url} sent a reply that is not a chat "
                                            f"completion: {resp.text[:300]}") from None
            usage = data.get("usage") or {}
            return Completion(text=text, input_tokens=int(usage.get("prompt_tokens", 0) or 0),
                              output_tokens=int(usage.get("completion_tokens", 0) or 0))

        return with_retries(once, what=f"{self.id} call", attempts=self.attempts,
                            base_delay=self.base_delay)
