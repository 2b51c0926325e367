"""No confounder added by grounding: a context entity keeps a state that does not explain the
ego's reaction on its own.

Expansion gives each cause event its entities, and some are context the cause's words do not
name: a traffic light beside "a pedestrian steps into the road". If such a light is red, a
careful driver stops for the light, whatever the pedestrian does, and the scenario no longer
shows that the pedestrian caused the stop (the but-for check, :mod:`regen.verify.causal`, calls
it ``confounded``). So before grounding, a context entity whose state alone makes drivers react
(:data:`CONTROLS`: a red, yellow or turning-red light; a siren on) gets the state that does not
(a green light, a siren off), unless the cause's words name that entity or that state. Each
such change is returned in words and recorded in the scenario's ``fallbacks`` (the verdict and
the report say it); nothing is changed silently.

A context entity that no map of the ego's behavior can host (a light where the ego is past the
junction after its turn) would make the whole scenario fail to ground: it is left out
(:func:`unhostable_context`), said the same way.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from regen.assets.database import AssetDatabase
from regen.core.graph import CausePath
from regen.core.words import name_words
from regen.verify.causal import answers_to_any, named_by_causes

#: property -> (states that make a driver react on their own, the state that does not)
CONTROLS: dict[str, tuple[frozenset[str], str]] = {
    "light_state": (frozenset({"red", "yellow", "turns_red"}), "green"),
    "siren": (frozenset({"on"}), "off"),
}


def _names_own_state(db: AssetDatabase, asset: str, prop: str, event: str, path: CausePath) -> bool:
    """Whether ``event`` names this entity's ``prop`` state, not another actor's motion whose
    words hold it ('a car runs the red light': the runner's red light, not the ego's)."""
    hit = db.named_state(asset, prop, event)
    if hit is None:
        return False
    words = set(name_words(hit[1]))
    motions = {m for pe in path.entities for m in pe.properties.get("behavior", [])}
    return not any(words <= set(name_words(m)) for m in motions)


def _cause_words(path: CausePath, db: AssetDatabase, robot: Sequence[str]) -> tuple[list[str], Any]:
    """(the cause events, what their words name): an entity they do not name is context."""
    causes = path.events[:-1] or path.events
    return causes, named_by_causes(db, causes, robot=robot)


def quiet_context(path: CausePath, db: AssetDatabase, *, robot: Sequence[str] = ()) -> tuple[CausePath, list[str]]:
    """(``path`` with its context entities' reacting states made neutral, what was changed in words)."""
    causes, named = _cause_words(path, db, robot)
    entities, notes = [], []
    for pe in path.entities:
        if answers_to_any(db, pe.asset, named):
            entities.append(pe)
            continue
        props = dict(pe.properties)
        for prop, (reacting, neutral) in CONTROLS.items():
            values = props.get(prop)
            if not values or not set(values) <= reacting or neutral not in (db.property_candidates(pe.asset, prop) or []):
                continue
            if any(_names_own_state(db, pe.asset, prop, event, path) for event in causes):
                continue  # the words name the state itself ('at a red light')
            props[prop] = [neutral]
            what = pe.asset.replace("_", " ")
            notes.append(f"{pe.asset} ({prop} = {'/'.join(values)} -> {neutral}): the cause's words do not name "
                         f"this {what} or its state, and a {what} with {prop} = {values[0]} would explain the "
                         f"ego's reaction on its own (a confounder)")
        entities.append(pe.model_copy(update={"properties": props}))
    return path.model_copy(update={"entities": entities}), notes


def unhostable_context(path: CausePath, db: AssetDatabase, *, robot: Sequence[str] = ()
                       ) -> tuple[CausePath, list[str]]:
    """(``path`` without its context entities that no map of the ego's behavior can host, what
    was left out in words). A context entity is one the cause's words do not name (as in
    :func:`quiet_context`): 'a pedestrian crosses the side road the ego turns into' with a
    traffic light the model added fails to ground where the ego is past the junction after its
    turn; without the light, the pedestrian's scenario grounds. An entity the words name is never
    left out (its scenario is ungroundable, and says why), nor the last one."""
    from regen.driving.grounding.rules import entity_host_problem

    _, named = _cause_words(path, db, robot)
    keep, notes = [], []
    for i, pe in enumerate(path.entities):
        why = None if answers_to_any(db, pe.asset, named) else entity_host_problem(path, i, db)
        if why is None:
            keep.append(pe)
            continue
        what = pe.asset.replace("_", " ")
        notes.append(f"{pe.asset} left out: the cause's words do not name this {what}, and the ego's behavior "
                     f"cannot meet one ({why.removeprefix('the map cannot host ')})")
    if not keep or not notes:
        return path, []
    return path.model_copy(update={"entities": keep}), notes


__all__ = ["CONTROLS", "quiet_context", "unhostable_context"]
