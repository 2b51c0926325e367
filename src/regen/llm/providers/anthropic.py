"""Anthropic's Messages API; structured answers through a forced tool call."""

from __future__ import annotations

import json
import os
from typing import Any

import httpx

from regen.errors import MissingAPIKeyError, ProviderResponseError
from regen.llm.base import Completion, Message, Provider, RetryableError, Sampling, with_retries
from regen.llm.providers.openai_compat import _retry_after

API_URL = "https://api.anthropic.com/v1/messages"


class AnthropicProvider(Provider):
    """``anthropic:<model>``. Key from ``ANTHROPIC_API_KEY``."""

    name = "anthropic"

    def __init__(self, model: str, *, api_key: str | None = None, base_url: str | None = None,
                 timeout: float = 120.0, attempts: int = 4, base_delay: float = 0.5):
        if not model:
            raise ProviderResponseError("name the model: anthropic:<model>")
        self.model = model
        self._key = api_key or os.environ.get("ANTHROPIC_API_KEY")
        if not self._key:
            raise MissingAPIKeyError("anthropic: no API key. Set it in the environment: "
                                     "export ANTHROPIC_API_KEY=... (or use --llm local)")
        self.url = (base_url or os.environ.get("REGEN_ANTHROPIC_BASE_URL") or API_URL)
        self.timeout = timeout
        self.attempts = attempts
        self.base_delay = base_delay
        self._client = httpx.Client(timeout=timeout)

    def complete(self, messages: list[Message], *, schema: dict[str, Any] | None,
                 sampling: Sampling) -> Completion:
        system = "\n\n".join(m["content"] for m in messages if m["role"] == "system")
        body: dict[str, Any] = {
            "model": self.model, "max_tokens": sampling.max_tokens,
            "temperature": sampling.temperature,
            "messages": [m for m in messages if m["role"] != "system"],
        }
        if system:
            body["system"] = system
        if schema is not None:
            body["tools"] = [{"name": "answer", "description": "Give the answer.", "input_schema": schema}]
            body["tool_choice"] = {"type": "tool", "name": "answer"}
        headers = {"x-api-key": self._key or "", "anthropic-version": "2023-06-01"}

        def once() -> Completion:
            try:
                resp = self._client.post(self.url, json=body, headers=headers)
            except httpx.TimeoutException:
                raise RetryableError(f"timeout after {self.timeout:.0f} s") from None
            except httpx.TransportError as exc:
                raise RetryableError(f"cannot reach {self.url} ({type(exc).__name__})") from None
            if resp.status_code in (429, 529) or resp.status_code >= 500:
                raise RetryableError(f"HTTP {resp.status_code}", _retry_after(resp))
            if resp.status_code in (401, 403):
                raise MissingAPIKeyError("Anthropic refused the API key; check ANTHROPIC_API_KEY")
            if resp.status_code >= 400:
                raise ProviderResponseError(f"Anthropic answered HTTP {resp.status_code}: {resp.text[:300]}")
            data = resp.json()
            text = ""
            for block in data.get("content", []):
                if block.get("type") == "tool_use":
                    text = json.dumps(block.get("input", {}))
                    break
                if block.get("type") == "text":
                    text += block.get("text", "")
            usage = data.get("usage") or {}
            return Completion(text=text, input_tokens=int(usage.get("input_tokens", 0)),
                              output_tokens=int(usage.get("output_tokens", 0)))

        return with_retries(once, what=f"{self.id} call", attempts=self.attempts,
                            base_delay=self.base_delay)
