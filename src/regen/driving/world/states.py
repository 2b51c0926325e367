"""The vocabulary of FSM states: a predicate call and a named state made of calls."""

from __future__ import annotations

from regen.core.scenario import PredicateCall


def pred(name: str, *args: str, negate: bool = False, **params: float | str) -> PredicateCall:
    """A predicate call, e.g. ``pred("in_front", "sedan1", "ego", distance=40.0)``."""
    return PredicateCall(name=name, args=list(args), params=params, negate=negate)


State = tuple[str, list[PredicateCall]]  # (state name, predicates that all hold in it)

__all__ = ["State", "pred"]
