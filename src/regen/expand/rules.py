"""Rules that reject a candidate cause the judge accepted, whatever the domain.

A small judge says yes to nearly every candidate; some of its mistakes are visible in the words
alone. A cause that happens somewhere else ("a jaywalker in another city", "a cyclist on a road
across the river", the paper's own example of an implausible edge) cannot directly cause what
the robot does here. These rules only ever reject: a cause they do not match is left to the
judge. The robot's own command, programming or mechanics is the domain's rule
(:attr:`regen.contract.Wording.mechanics`), and so are the causes that make the robot do the
opposite of what it did (:attr:`regen.contract.Wording.opposites`), which :func:`opposite_of`
applies.

Imports: the shared core only.
"""

from __future__ import annotations

import re
from collections.abc import Sequence

from regen.assets.matching import without_robot
from regen.core.words import lowered

_PLACE = (r"(?:city|town|country|state|province|village|district|neighbou?rhood|suburb|street|road|"
          r"highway|motorway|freeway|continent|region|county|planet|part\s+of\s+(?:town|the\s+city|the\s+country))")

#: Phrases that put a cause somewhere other than where the robot acts; searched in the
#: lower-cased cause text with ``re.search``. "From another road" is not here: a car from
#: another road can enter the robot's.
ELSEWHERE: tuple[re.Pattern[str], ...] = tuple(re.compile(p) for p in (
    r"\b(?:in|on|at|inside)\s+(?:another|a\s+different|a\s+distant|a\s+faraway|a\s+far-away|a\s+far\s+away|"
    r"some\s+other|the\s+next|a\s+neighbou?ring)\s+" + _PLACE + r"\b",
    r"\b(?:on\s+|at\s+|in\s+)?the\s+(?:other|far)\s+(?:side|end)\s+of\s+(?:the\s+)?(?:town|city|country|world|"
    r"river|lake|valley|bay|state)\b",
    r"\bacross\s+(?:the\s+)?(?:river|town|city|country|lake|sea|ocean|bay|border|valley)\b",
    r"\b(?:far\s+away|far\s+off|far\s+from\s+(?:here|the\s+\w+)|(?:miles|kilometers|kilometres|blocks)\s+away)\b",
    r"\b(?:abroad|overseas)\b",
))


def happens_elsewhere(cause: str) -> str | None:
    """The words that place ``cause`` somewhere other than where the robot acts, or None."""
    text = lowered(cause)
    for rx in ELSEWHERE:
        if m := rx.search(text):
            return m.group(0).strip()
    return None


def opposite_of(cause: str, effect: str, opposites: Sequence[tuple[str, str, str]],
                robot_names: Sequence[str]) -> tuple[str, str] | None:
    """(the cause's words, what they make the robot do instead) when ``cause`` makes the robot do
    the opposite of ``effect`` by one of ``opposites`` (a domain's ``Wording.opposites``, tried in
    order: the first whose effect pattern matches decides, so 'drove off from a stop' is a
    drive-off); only an effect that names the robot (one of ``robot_names``) is tested."""
    said = lowered(effect)
    if " itself " not in without_robot(effect, robot_names):  # 'the car ahead stops' is another car
        return None
    text = lowered(cause)
    for effect_rx, cause_rx, instead in opposites:  # the first kind of effect it is decides
        if re.search(effect_rx, said):
            m = re.search(cause_rx, text)
            return (m.group(0).strip(), instead) if m else None
    return None
