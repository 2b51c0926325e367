"""Shrinking a failing candidate to the fewest edits that still make the policy fail.

A pure function over sets of edits and an oracle: the search passes an oracle that looks a set
up among the candidates already run (by key) and runs it only when it is new and the budget
allows; the tests pass a fake one.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Hashable, Sequence
from dataclasses import dataclass, field
from typing import Generic, TypeVar

K = TypeVar("K", bound=Hashable)

#: What the oracle says of a set of edits: 'failed' (the policy fails while the scripted robot
#: verified), 'passed', 'invalid', 'error', or None (not known: the budget is spent).
Outcome = Callable[[tuple[K, ...]], "str | None"]


@dataclass
class Shrunk(Generic[K]):
    """The smallest failing set found, the chain of failing sets from the original to it, and
    whether it is minimal: every proper subset was tried and none fails."""

    edits: tuple[K, ...]
    chain: list[tuple[K, ...]] = field(default_factory=list)
    minimal: bool = False


def _proper_subsets(edits: tuple[K, ...], size: int) -> list[tuple[K, ...]]:
    return [tuple(c) for c in itertools.combinations(edits, size)]


def shrink(edits: Sequence[K], outcome: Outcome) -> Shrunk[K]:
    """Shrink the failing set ``edits``: step to a failing subset one edit smaller while there
    is one (subsets tried in a fixed order: the last edit dropped first), then try the smaller
    proper subsets of where it stopped (a set whose every one-smaller subset passes may still
    hold a failing pair when edits interact); it is minimal when no proper subset fails and
    none is unknown. ``outcome`` is asked each subset at most once."""
    asked: dict[tuple[K, ...], str | None] = {}

    def ask(s: tuple[K, ...]) -> str | None:
        if s not in asked:
            asked[s] = outcome(s)
        return asked[s]

    current = tuple(edits)
    chain = [current]
    while True:
        smaller = next((s for s in _proper_subsets(current, len(current) - 1)
                        if len(current) > 1 and ask(s) == "failed"), None)
        if smaller is not None:
            current = smaller
            chain.append(current)
            continue
        deeper = next((s for size in range(1, len(current) - 1) for s in _proper_subsets(current, size)
                       if ask(s) == "failed"), None)
        if deeper is None:
            break
        current = deeper
        chain.append(current)
    subsets = [s for size in range(1, len(current)) for s in _proper_subsets(current, size)]
    minimal = all(asked.get(s) is not None for s in subsets)
    return Shrunk(edits=current, chain=chain, minimal=minimal)


__all__ = ["Outcome", "Shrunk", "shrink"]
