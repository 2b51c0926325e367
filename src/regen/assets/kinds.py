"""Kinds of being a cause names without naming an asset: a person, an animal.

A cause may name who takes part in words no asset carries: 'grandma wants to read', 'the
neighbour's boy', 'a puppy scratches at the door'. Whatever asset plays them, the scenario must
show a person (an animal) then: a book and a trash can do not show grandma. These are plain
English word lists, not a domain's: an asset is of a kind when its id or an alias says so
('adult', alias 'person'), and in a domain whose agents are road users every agent carries a
person (a car has its driver, a bicycle its rider).

A word names an actor of the cause, not its owner or a past doer: 'grandma's glasses' and 'the
toys left by the children' need no person in the scene.

Imports: the shared core and the assets' name rules only.
"""

from __future__ import annotations

import re
from collections.abc import Sequence

from regen.assets.matching import without_robot
from regen.core.words import singular, surface_words

#: Words (singular, lower case) that name a person.
PERSON_WORDS = frozenset("""
person human man woman lady gentleman guy adult grownup child kid baby toddler infant boy girl teen
teenager youngster schoolchild schoolkid student pupil guest visitor friend neighbor neighbour
grandma granny grandmother grandpa grandfather grandparent grandchild grandson granddaughter mom
mum mommy mummy mother dad daddy father parent husband wife spouse son daughter brother sister
sibling uncle aunt cousin nephew niece roommate flatmate housemate tenant resident family host
courier postman mailman postwoman plumber electrician nurse caregiver carer patient elderly senior
pensioner pedestrian jaywalker jogger runner walker hiker hitchhiker passenger officer policeman
policewoman cop worker workman flagger guard chef
""".split())

#: Words (singular, lower case) that name an animal.
ANIMAL_WORDS = frozenset("""
animal pet dog puppy doggy cat kitten kitty hamster rabbit bunny parrot budgie bird deer fox horse
cow sheep goat duck goose squirrel raccoon hedgehog moose elk boar cattle livestock
""".split())

KINDS: dict[str, frozenset[str]] = {"person": PERSON_WORDS, "animal": ANIMAL_WORDS}


def _word_kind(word: str) -> str | None:
    for w in (word, singular(word), word[:-3] + "y" if word.endswith("ies") else word):
        for kind, words in KINDS.items():
            if w in words:
                return kind
    return None


def beings_named(text: str, *, exclude: str | Sequence[str] = ()) -> dict[str, str]:
    """Kind -> the first word of ``text`` that names a being of that kind as an actor of the
    cause. Skipped: possessives ('grandma's book'), doers after 'by' ('left by the children'),
    and the phrases of ``exclude`` (what the domain calls its robot)."""
    raw = without_robot(text, exclude)
    raw = re.sub(r"\b[a-z]+s?'s?(?=\s|$)", " ", raw)  # possessives: their owner is not in the scene
    raw = re.sub(r"\bby\s+(?:(?:the|a|an|my|our|his|her|their|its)\s+)?[a-z]+", " ", raw)
    out: dict[str, str] = {}
    for word in surface_words(raw):
        kind = _word_kind(word)
        if kind is not None and kind not in out:
            out[kind] = word
    return out


def kinds_of(asset: str, aliases: Sequence[str], *, carries_people: bool = False) -> frozenset[str]:
    """The kinds of being an asset is, from the words of its id and aliases; ``carries_people``:
    it is a road user with a driver or rider aboard (a person)."""
    kinds = {k for name in (asset, *aliases) for w in surface_words(name) if (k := _word_kind(w))}
    if carries_people:
        kinds.add("person")
    return frozenset(kinds)
