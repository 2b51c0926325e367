"""Verified manipulation scenarios without a model: rule-based grounding with explicit placements."""

from __future__ import annotations


def door_scenario(choices: dict[str, tuple[str, str]], assets: list[str], seed: int = 0):
    """'the robot opens the door' grounded by the rules, with ``choices`` (entity -> (relation,
    reference)) fixed and nothing relaxed."""
    from regen.core import Behavior, CausePath, PathEntity
    from regen.manipulation.grounding.ground import ground_path
    from regen.manipulation.world.tasks import BEHAVIORS

    b = BEHAVIORS["open_door"]
    path = CausePath(behavior=Behavior(text=b.text, domain="manipulation", params={"reward": b.id}),
                     events=["the pet wants to go out", b.text],
                     entities=[PathEntity(asset=a, event="the pet wants to go out") for a in assets])
    sc = ground_path(path, None, seed=seed, relax=False, choices=choices)
    assert sc.solver.status in ("optimal", "feasible"), sc.solver.conflicts
    return sc


def pet_door_path():
    """The cause path 'the pet wants to go out' -> 'the robot opens the door' (for rule grounding)."""
    from regen.core import Behavior, CausePath, PathEntity
    from regen.manipulation.world.tasks import BEHAVIORS

    b = BEHAVIORS["open_door"]
    return CausePath(behavior=Behavior(text=b.text, domain="manipulation", params={"reward": b.id}),
                     events=["the pet wants to go out", b.text],
                     entities=[PathEntity(asset="pet", event="the pet wants to go out")])
