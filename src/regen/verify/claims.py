"""What a model's narrative claims against what the simulation shows.

A narrative is the model's text; the scenario's claims are checked by simulation. A sentence
that says something happened that the trace does not show (a collision where nobody collided, a
stop of the robot that never stood still) is marked as the model's claim, with what the
simulation shows instead: :func:`check_narrative` returns those notes, the verdict keeps them
(``Verdict.claims``) and the report shows them beside the narrative. Negated or hypothetical
mentions ("to avoid a collision", "could have crashed") claim nothing. A state the words name
(:func:`check_states`: "the light is red", "its siren blaring") that no entity of that kind ever
showed in the run is marked the same way: grounding may have changed what the model wrote (a
context light it made red is green in the scenario, :mod:`regen.driving.grounding.confounders`).

Imports: the standard library only (the asset database is passed in).
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from typing import Protocol

_SENTENCE = re.compile(r"[^.!?]+[.!?]?")
_COLLISION = re.compile(r"\b(collid\w*|collision\w*|crash\w*|hits|hit|struck|strikes|runs over|ran over)\b",
                        re.IGNORECASE)
_STOP = re.compile(r"\b(stops|stopped|comes to a (?:halt|stop)|came to a (?:halt|stop)|halts|halted)\b",
                   re.IGNORECASE)
#: words before a claim in its sentence that make it no claim of fact
_HEDGE = re.compile(r"\b(avoid\w*|prevent\w*|without|no|not|never|near|almost|nearly|risk\w*|potential\w*|"
                    r"possible|possibly|could|would|might|may|if|danger\w*|threat\w*|before|unless)\b",
                    re.IGNORECASE)


def _claimed(sentence: str, pattern: re.Pattern[str]) -> str | None:
    m = pattern.search(sentence)
    if m is None or _HEDGE.search(sentence[: m.start()]):
        return None
    return m.group(0)


def check_narrative(text: str, *, collisions: list[str] | None, robot_stood: bool | None, robot: str = "robot"
                    ) -> list[str]:
    """Notes on the sentences of ``text`` that claim what the trace does not show.
    ``collisions``: the collisions the simulation found, in words (None: not known, no check);
    ``robot_stood``: whether the robot stood still at some point (None: no check)."""
    notes = []
    for s in _SENTENCE.findall(text):
        sentence = s.strip()
        if not sentence:
            continue
        word = _claimed(sentence, _COLLISION)
        if word and collisions is not None and not collisions:
            notes.append(f"the model's claim: '{sentence}' ('{word}'); the simulation shows no collision")
        word = _claimed(sentence, _STOP)
        if word and robot_stood is False and robot.lower() in sentence.lower():
            notes.append(f"the model's claim: '{sentence}' ('{word}'); in the simulation the {robot} never stands still")
    return notes


class NamesStates(Protocol):
    """What :func:`check_states` asks of the asset database."""

    def parameters_of(self, asset: str) -> Sequence[str]: ...

    def named_states(self, asset: str, prop: str, event: str) -> dict[str, str]: ...


def check_states(text: str, cast: Sequence[tuple[str, str]], shown: Mapping[str, Mapping[str, set[str]]],
                 db: NamesStates) -> list[str]:
    """Notes on the sentences of ``text`` that name a property state (not a motion) which no
    entity of ``cast`` ((name, asset) pairs) that has the property ever showed; ``shown``:
    entity -> property -> every state it had in the run."""
    notes = []
    for s in _SENTENCE.findall(text):
        sentence = s.strip()
        for prop in dict.fromkeys(p for _, a in cast for p in db.parameters_of(a)):
            if prop == "behavior":
                continue  # motions are the fidelity check's (verify.fidelity), not a state
            holders = [(n, a) for n, a in cast if prop in db.parameters_of(a)]
            named = {st: ph for _, a in holders for st, ph in db.named_states(a, prop, sentence).items()}
            if len(named) != 1:
                continue  # nothing named, or several states (several actors): no claim to check
            ((state, phrase),) = named.items()
            at = sentence.lower().find(phrase.lower())
            if at >= 0 and _HEDGE.search(sentence[:at]):
                continue
            if any(state in shown.get(n, {}).get(prop, set()) for n, _ in holders):
                continue
            had = "; ".join(f"{n} has {prop} = {', '.join(sorted(shown.get(n, {}).get(prop, set()))) or '?'}"
                            for n, _ in holders)
            notes.append(f"the model's claim: '{sentence}' ('{phrase}'); in the simulation {had}")
    return notes


__all__ = ["check_narrative", "check_states"]
