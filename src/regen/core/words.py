"""The words of a name as the toolkit compares names: lower case, singular, no articles.

One home for the comparison the asset database, expansion and the fidelity check share, so
that 'the traffic lights' and 'traffic_light' are the same two words everywhere.
"""

from __future__ import annotations

import re

#: Words that never tell two names apart.
STOPWORDS = frozenset({"a", "an", "the", "some", "one", "two", "three", "its", "their", "his", "her", "own"})


#: English plurals no ending rule undoes.
IRREGULAR_PLURALS = {"children": "child", "people": "person", "men": "man", "women": "woman",
                     "feet": "foot", "geese": "goose", "mice": "mouse", "teeth": "tooth",
                     "policemen": "policeman", "policewomen": "policewoman"}


def lowered(text: str) -> str:
    """``text`` as the rules search it: lower case, a typographic apostrophe as a plain one,
    single spaces."""
    return " ".join(text.lower().replace("\u2019", "'").split())


def singular(word: str) -> str:
    """``word`` without a plural ending (a rule and a few irregular plurals, not a dictionary:
    'benches' -> 'bench', 'children' -> 'child')."""
    if word in IRREGULAR_PLURALS:
        return IRREGULAR_PLURALS[word]
    if len(word) > 4 and word.endswith(("ches", "shes", "xes", "sses")):
        return word[:-2]
    if len(word) > 3 and word.endswith("s") and not word.endswith(("ss", "us", "is")):
        return word[:-1]
    return word


def surface_words(text: str) -> list[str]:
    """The words of a name as written (lower case, no articles), not made singular."""
    text = re.sub(r"[^a-z0-9 ]+", " ", text.lower().replace("_", " ").replace("-", " "))
    return [w for w in text.split() if w not in STOPWORDS]


def name_words(text: str) -> list[str]:
    """The words of a name as matching compares them: lower case, singular, no articles."""
    return [singular(w) for w in surface_words(text)]


def has_phrase(words: list[str], phrase: list[str]) -> bool:
    """Whether ``phrase`` occurs in ``words`` as consecutive whole words (both as
    :func:`name_words` gives them)."""
    n = len(phrase)
    return n > 0 and any(words[i:i + n] == phrase for i in range(len(words) - n + 1))
