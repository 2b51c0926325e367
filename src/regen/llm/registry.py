"""Providers chosen by one string: ``local[:model]``, ``openai:<model>``, ``anthropic:<model>``.

Third-party providers register a factory with :func:`register_provider`.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from typing import Any

from regen.errors import UnknownProviderError
from regen.llm.base import Provider

_FACTORIES: dict[str, str | Callable[..., Provider]] = {
    "local": "regen.llm.providers.local:LocalProvider",
    "openai": "regen.llm.providers.openai_compat:OpenAIProvider",
    "anthropic": "regen.llm.providers.anthropic:AnthropicProvider",
}


def register_provider(prefix: str, factory: str | Callable[..., Provider]) -> None:
    """Register ``prefix`` -> a factory called as ``factory(model, **options)``."""
    _FACTORIES[prefix] = factory


def get_provider(spec: str, **options: Any) -> Provider:
    """Make the provider named by ``spec`` (e.g. ``openai:gpt-4o-mini``)."""
    prefix, _, model = spec.strip().partition(":")
    factory = _FACTORIES.get(prefix)
    if factory is None:
        raise UnknownProviderError(
            f"unknown LLM provider {spec!r}; use one of: local, local:<model or .gguf path>, "
            "openai:<model> (OpenAI or a compatible server via REGEN_OPENAI_BASE_URL), "
            "anthropic:<model>")
    if isinstance(factory, str):
        module, _, name = factory.partition(":")
        factory = getattr(importlib.import_module(module), name)
    return factory(model, **options)
