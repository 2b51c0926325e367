"""Merging duplicate and near-duplicate candidate texts.

Content words are compared without the shared English stop words below and without the domain's
own (``Wording.stop_words``, e.g. its words for the robot), which callers pass as ``stop``.
"""

from __future__ import annotations

import re
from collections.abc import Collection
from difflib import SequenceMatcher

STOP_WORDS = frozenset({"a", "an", "the", "is", "are", "of", "to", "in", "on", "at", "and", "its", "it",
                        "by", "from", "with", "suddenly", "abruptly"})


def normalize(text: str) -> str:
    return " ".join(re.sub(r"[^a-z0-9 ]+", " ", text.lower()).split())


def _tokens(text: str, stop: Collection[str] = ()) -> set[str]:
    return {t for t in normalize(text).split() if t not in STOP_WORDS and t not in stop}


def similar(a: str, b: str, threshold: float = 0.85, *, stop: Collection[str] = ()) -> bool:
    """True when two texts say the same thing (same content words, or nearly the same text);
    ``stop``: the domain's stop words, ignored like the shared ones."""
    na, nb = normalize(a), normalize(b)
    if na == nb:
        return True
    ta, tb = _tokens(a, stop), _tokens(b, stop)
    if ta and ta == tb:
        return True
    if ta and tb and len(ta & tb) / len(ta | tb) >= 0.8:
        return True
    # one says all the other says and a little more ("... in front" / "... in front of the car")
    small, big = sorted((ta, tb), key=len)
    if len(small) >= 3 and small <= big and len(big) - len(small) <= 2:
        return True
    return SequenceMatcher(None, na, nb).ratio() >= threshold


def merge(candidates: list[str], existing: list[str] = (), *,
          stop: Collection[str] = ()) -> tuple[list[str], dict[str, str]]:
    """Unique candidates in order, and a map from each dropped candidate to what it merged into
    (an earlier candidate or an ``existing`` text); ``stop``: the domain's stop words."""
    kept: list[str] = []
    merged: dict[str, str] = {}
    for c in candidates:
        old = next((e for e in existing if similar(c, e, stop=stop)), None)
        if old is not None:
            merged[c] = old
            continue
        dup = next((k for k in kept if similar(c, k, stop=stop)), None)
        if dup is None:
            kept.append(c)
        elif c != dup:
            merged[c] = dup
    return kept, merged
