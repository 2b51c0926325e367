"""Pull the JSON object out of a model's answer text (code fences and chatter around it)."""

from __future__ import annotations

import json
from typing import Any


def extract_json(text: str) -> Any:
    """Parse the first complete JSON object or array in ``text``; raise ValueError if none."""
    stripped = text.strip()
    try:
        return json.loads(stripped)
    except json.JSONDecodeError:
        pass
    decoder = json.JSONDecoder()
    for i, ch in enumerate(stripped):
        if ch in "{[":
            try:
                value, _ = decoder.raw_decode(stripped, i)
                return value
            except json.JSONDecodeError:
                continue
    raise ValueError("the answer contains no JSON object")
