"""Caused, not only verified: the but-for check of a scenario's cause.

The FSM monitor proves that the cause played out before the robot's reaction; but the scripted
robot reacts at its solved time whatever the world does, so that proves order, not cause. A
domain that has a *reference robot* (driving: a careful driver, IDM and MOBIL, that reacts only
to what it perceives) gives a :class:`ReferenceWorld`: the scenario's world, simulated with the
reference robot, with some entities left out. On it :func:`but_for` decides:

1. **sufficient**: with everything present, the reference shows the behavior class as a
   reaction to the cause (by its own account of what it reacted to, or else after the cause
   first shows); where it shows it for another entity, the confounder check (3) still runs;
2. **necessary**: with the cause's entities removed (the rest of the world and the solved
   parameters kept), it does not;
3. **confounders**: for each other entity, whether it alone (the cause removed, it kept)
   makes the reference show the behavior, and whether the behavior is still shown without it;
   an entity that explains the behavior on its own is a confounder, named.

Which entities are the cause (:func:`split_cast`): those the cause's words name (the assets of
the database they name); where the words name none, the entities the causal graph chose for the
cause; every other entity is tested as a possible confounder.

Imports: the shared core and assets; no domain.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import TYPE_CHECKING, Protocol

from regen.core.verdict import Causal, EntityCheck, ReferenceRun

if TYPE_CHECKING:
    from regen.assets.database import AssetDatabase
    from regen.core.scenario import Scenario


class NotCheckable(Exception):  # noqa: N818 (a reason, not a failure)
    """The domain cannot check this scenario's cause by simulation; the message says why."""


class ReferenceWorld(Protocol):
    """A scenario's world with the domain's reference robot in it."""

    #: the reference robot, in words ("reference driver (IDM following, MOBIL lane changes)")
    by: str
    #: the behavior class it must show ("stops", "slows down", "changes lane", "drives off")
    behavior: str

    def run(self, removed: frozenset[str]) -> ReferenceRun:
        """Simulate with the entities ``removed`` left out; whether the behavior is shown."""
        ...


def named_by_causes(db: AssetDatabase, events: Sequence[str], *, robot: Sequence[str] = (),
                    own: frozenset[str] = frozenset()) -> set[str]:
    """The asset names (ids and the names they were called by) that the cause ``events`` name,
    in words or by words that together imply one."""
    named: set[str] = set()
    for event in events:
        hits = db.named_in(event, exclude=robot, skip=own)
        hits += db.implied_by_words(event, exclude=robot, skip=own | {m.asset for m in hits})
        named |= {m.key for m in hits} | {m.asset for m in hits}
    return named


def answers_to_any(db: AssetDatabase, asset: str, named: set[str]) -> bool:
    """Whether an entity of ``asset`` plays one of the ``named`` assets."""
    return asset in db.assets and any(asset == n or db.answers_to(asset, n) for n in named)


def split_cast(scenario: Scenario, db: AssetDatabase, *, robot: Sequence[str] = (),
               own: frozenset[str] = frozenset(), graph_assets: Sequence[str] | None = None
               ) -> tuple[list[str], list[str], str]:
    """(the cause's entity names, the other entities' names, how the cause was found).

    The cause is the entities answering to an asset the cause events' words name; where they
    name none, the entities the causal graph chose (``graph_assets``, in order, matched by
    asset); without those, every entity."""
    cast = [e for e in scenario.entities if not e.is_robot and e.asset not in own]
    named = named_by_causes(db, scenario.causal_graph[:-1] or scenario.causal_graph, robot=robot, own=own)
    cause = [e.name for e in cast if answers_to_any(db, e.asset, named)]
    if cause:
        return cause, [e.name for e in cast if e.name not in cause], "named by the cause's words"
    if graph_assets is not None:
        left = list(graph_assets)
        for e in cast:
            if e.asset in left:
                left.remove(e.asset)
                cause.append(e.name)
        if cause:
            return cause, [e.name for e in cast if e.name not in cause], "chosen by the causal graph"
    return [e.name for e in cast], [], "every entity of the scenario"


def _base(what: str) -> str:
    """'stops' -> 'stop', 'changes lane' -> 'change lane': the behavior after 'does not'."""
    first, _, rest = what.partition(" ")
    first = first[:-1] if first.endswith("s") else first
    return f"{first} {rest}".strip()


def _names(names: Iterable[str]) -> str:
    names = list(names)
    return ", ".join(names) if names else "nothing"


def but_for(world: ReferenceWorld, cause: Sequence[str], others: Sequence[str], *,
            cause_from: str = "") -> Causal:
    """The but-for check of ``cause`` in ``world`` (module docstring). Runs the reference
    2 times, plus 2 per other entity (1 when there is only one)."""
    base = {"by": world.by, "behavior": world.behavior, "cause": list(cause), "cause_from": cause_from}
    what = world.behavior
    full = world.run(frozenset())
    full.removed = []
    if not full.shown and not (full.happened and others):
        if not cause:
            reason = f"with no entity of the cause in the scene, the {world.by} does not {_base(what)}: {full.summary}"
        else:
            reason = f"with {_names(cause)}, the {world.by} does not {_base(what)}: {full.summary}"
        return Causal(status="not_sufficient", reason=reason, with_cause=full, **base)
    without = world.run(frozenset(cause))
    without.removed = list(cause)
    checks: list[EntityCheck] = []
    for o in others:
        rest = frozenset(cause) | (frozenset(others) - {o})
        if len(others) == 1:
            alone = without.shown
        else:
            alone = world.run(rest).shown
        without_it = world.run(frozenset({o})).shown
        checks.append(EntityCheck(entity=o, alone_shows=alone, without_it_shows=without_it))
    confounders = [c.entity for c in checks if c.alone_shows]
    if confounders:
        return Causal(status="confounded", with_cause=full, without_cause=without, others=checks,
                      confounders=confounders,
                      reason=f"{_names(confounders)} alone makes the {world.by} {_base(what)}, without "
                             f"{_names(cause)}: {without.summary}", **base)
    if not full.shown:  # it reacted, but to something else, and nothing else alone explains it
        return Causal(status="not_sufficient", with_cause=full, without_cause=without, others=checks,
                      reason=f"with {_names(cause)}, the {world.by} does not {_base(what)} for it: "
                             f"{full.summary}", **base)
    if without.shown:
        rest = [c.entity for c in checks]
        else_ = f"the other entities together ({_names(rest)})" if rest else "the road alone"
        return Causal(status="not_necessary", with_cause=full, without_cause=without, others=checks,
                      reason=f"the {world.by} {what} without {_names(cause)} too, for "
                             f"{else_}: {without.summary}", **base)
    return Causal(status="caused", with_cause=full, without_cause=without, others=checks,
                  reason=f"the {world.by} {full.summary}; with {_names(cause)} removed it does not "
                         f"({without.summary})", **base)


def not_checked(reason: str) -> Causal:
    return Causal(status="not_checked", reason=reason)


def explains(causal: Causal | None, feasible: bool) -> bool:
    """Whether a verified scenario explains its robot's behavior: its FSM played out and, where
    the cause was checked by simulation, it caused the behavior."""
    if not feasible:
        return False
    return causal is None or causal.status in ("caused", "not_checked")


__all__ = ["NotCheckable", "ReferenceWorld", "answers_to_any", "but_for", "explains", "named_by_causes",
           "not_checked", "split_cast"]
