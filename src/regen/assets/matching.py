"""How the toolkit compares names: a model-written name with an asset's names, a text's
phrases with them (rules, and sentence embeddings for paraphrases), with the robot's own words
blanked. The queries that use these are :class:`~regen.assets.database.AssetDatabase`'s.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from difflib import SequenceMatcher
from functools import lru_cache
from typing import Any

from regen.core.words import STOPWORDS, lowered, name_words

#: Least similarity (0-1) at which a model-written entity name is taken for an asset.
MATCH_THRESHOLD = 0.75
#: Descriptions are longer and looser than ids and aliases: their matches count a little less.
DESCRIPTION_WEIGHT = 0.95
#: Without a shared head noun, only near-identical spellings count (typos: 'ambulence').
SPELLING = 0.85
#: Least cosine (all-MiniLM-L6-v2) between a phrase of a cause text and an asset's id or alias
#: for the phrase to name that asset ('mopping floor' / 'floor mop': 0.89). Chosen on the tune
#: half of the bundled fidelity sets (72 texts, 5 of which name no asset by a name or state):
#: from 0.70 to 0.85 one paraphrase is found and it is a labeled entity (a floor mop); at 0.60
#: four are right ('enforcement' -> police, 'driver' -> vehicle) and one wrong ('a jogger runs
#: along the road' -> road assistance, 0.67); a 'cleaning cloth' of the tune half is 0.76 from
#: 'clothing'. 0.80 keeps a margin above both.
PARAPHRASE_THRESHOLD = 0.80
#: Words that begin or end no phrase compared by meaning.
FUNCTION_WORDS = frozenset({*STOPWORDS, "in", "on", "at", "of", "to", "for", "from", "by", "with", "and",
                             "or", "is", "are", "was", "be", "been", "has", "have", "had", "it", "itself",
                             "into", "onto", "off", "out", "up", "as", "than", "that", "this", "while",
                             "about", "after", "before", "not", "no", "must", "can", "might", "will"})

_CUT = re.compile(r"[:;,()]|\b(?:with|of|on|in|at|for|from|by|near|under|over|behind|beside|"
                  r"that|which|who|and|or)\b")


# Words after 'the vehicle' that make it another vehicle than the robot ('the vehicle ahead').
_PLACE_AFTER = ("ahead", "in front", "in the", "in its", "behind", "next", "beside", "parked", "opposite",
                "oncoming", "to the", "to its", "on the", "at the", "that", "which", "who", "coming", "approaching")


def without_robot(text: str, names: str | Sequence[str]) -> str:
    """``text`` with every phrase that names the robot itself blanked (longest first); ``names``:
    one phrase or several."""
    names = [names] if isinstance(names, str) else list(names)
    out = lowered(text)
    place = "|".join(re.escape(p) for p in _PLACE_AFTER)
    for name in sorted((n.lower() for n in names if n.strip()), key=len, reverse=True):
        pattern = rf"(?<![\w-]){re.escape(name)}(?![\w-])"
        if name.startswith("the "):  # a definite 'the vehicle' is the robot, unless placed elsewhere
            pattern += rf"(?!\s+(?:{place})\b)"
        out = re.sub(pattern, " itself ", out)  # a word no asset is named by
    return out


def plain(text: str) -> str:
    """``text`` as state phrases are looked for: lower case, hyphens as spaces, single spaces."""
    return " ".join(text.lower().replace("-", " ").split())


@lru_cache(maxsize=4096)
def _phrase_pattern(phrase: str) -> re.Pattern[str]:
    """The whole-word pattern of a state phrase (compiled once: the database's phrases are few)."""
    return re.compile(rf"\b{re.escape(plain(phrase))}\b")


def phrases_in(event: str, named_by: dict[str, dict[str, list[str]]]) -> list[tuple[str, str, str]]:
    """(key, state, phrase) for every phrase of ``named_by`` (key -> state -> phrases) in
    ``event``: whole words, any case, the longest phrase where they overlap."""
    text = plain(event)
    found = [(m.start(), m.end(), key, st, ph) for key, states in named_by.items()
             for st, phrases in states.items()
             for ph in phrases for m in _phrase_pattern(ph).finditer(text)]
    out: list[tuple[str, str, str]] = []
    for a0, a1, key, st, ph in sorted(found, key=lambda f: f[0] - f[1]):
        if any(b0 <= a0 and a1 <= b1 and (b0, b1) != (a0, a1) for b0, b1, *_ in found):
            continue
        if (key, st, ph) not in out:
            out.append((key, st, ph))
    return out


def main_phrases(description: str) -> list[str]:
    """The noun phrases a description names its asset by: the words before the first
    preposition or participle ('car parked at the roadside' -> 'car'), and after a colon
    ('emergency vehicle: ambulance' -> 'emergency vehicle', 'ambulance')."""
    out: list[str] = []
    for part in description.lower().split(":"):
        words = name_words(_CUT.split(part.strip(), maxsplit=1)[0])
        for i, w in enumerate(words[1:], start=1):
            if w.endswith(("ing", "ed")):  # 'debris lying ...'; a first word is an adjective ('potted')
                words = words[:i]
                break
        if words:
            out.append(" ".join(words))
    return out


def similarity(name: str, key: str) -> float:
    """How likely ``name`` means the thing ``key`` names, from 0 to 1 (deterministic).

    Noun phrases are compared by their head noun (the last word): when both have the same head,
    0.6 plus 0.4 times the share of words they have in common ('watering plant'
    / 'plant': 0.8; 'coffee cup' / 'cup': 0.8; 'watering can' / 'trash can': 0.73); otherwise
    only near-identical spellings count ('ambulence' / 'ambulance': 0.89), never a shared
    modifier ('storage furniture' / 'storage box': 0; 'road' / 'road block': 0).
    """
    n, k = name_words(name), name_words(key)
    if not n or not k:
        return 0.0
    if n == k:
        return 1.0
    score = 0.0
    if n[-1] == k[-1]:
        sn, sk = set(n), set(k)
        score = 0.6 + 0.4 * len(sn & sk) / len(sn | sk)
    ratio = SequenceMatcher(None, "".join(n), "".join(k)).ratio()
    return max(score, ratio if ratio >= SPELLING else 0.0)


@lru_cache(maxsize=8)
def key_vectors(encoder: Any, keys: tuple[str, ...]) -> Any:
    """The embeddings of a database's names, once per encoder and name list."""
    return encoder.encode(list(keys))
