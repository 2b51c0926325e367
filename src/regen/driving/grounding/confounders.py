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
"""

from __future__ import annotations

from collections.abc import Sequence

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


def quiet_context(path: CausePath, db: AssetDatabase, *, robot: Sequence[str] = ()) -> tuple[CausePath, list[str]]:
    """(``path`` with its context entities' reacting states made neutral, what was changed in words)."""
    causes = path.events[:-1] or path.events
    named = named_by_causes(db, causes, robot=robot)
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


__all__ = ["CONTROLS", "quiet_context"]
