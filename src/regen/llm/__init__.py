"""One interface for structured model calls: messages in, a validated pydantic model out.

``LLM("local")``, ``LLM("openai:gpt-4o")``, ``LLM("anthropic:claude-sonnet-4-5")``; every call is
cached in SQLite, replayable, counted, and re-asked when the answer does not validate.
"""

from regen.llm.base import Completion, Message, Provider, Sampling
from regen.llm.client import LLM, Answered, UsageStats
from regen.llm.registry import get_provider

__all__ = ["LLM", "Answered", "Completion", "Message", "Provider", "Sampling", "UsageStats", "get_provider"]
