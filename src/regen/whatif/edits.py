"""A what-if's edits of a cause chain (``set``, ``remove``, ``add``) and how they apply.

:func:`apply_edits` turns the original scenario's cause path into the counterfactual's: every
entity keeps the values the original scenario had (its behavior, states and start place pinned),
so only what the edits touch changes. A question in words goes to the model, which answers with
edits (:func:`ask_edits`): data validated by pydantic and by :func:`apply_edits`, never executed.
"""

from __future__ import annotations

import json
import re
from typing import TYPE_CHECKING, Any, Literal

from pydantic import Field

from regen import domains
from regen.core.base import Answer, Model
from regen.errors import ConfigError

if TYPE_CHECKING:
    from regen.assets.database import AssetDatabase
    from regen.core.graph import CausePath
    from regen.core.scenario import Scenario
    from regen.llm.client import LLM


class Edit(Model):
    """One change to a cause chain."""

    op: Literal["set", "remove", "add"]
    entity: str | None = None  # the scenario's entity name (set, remove)
    property: str | None = None  # set
    value: str | None = None  # set
    text: str | None = None  # add: the new cause event

    def describe(self) -> str:
        if self.op == "set":
            return f"set {self.entity}.{self.property} = {self.value}"
        if self.op == "remove":
            return f"remove {self.entity}"
        return f"add cause '{self.text}'"


class Edits(Answer):
    """The model's answer to a what-if question."""

    edits: list[Edit] = Field(min_length=1, max_length=6)


def parse_set(text: str) -> Edit:
    """``ENTITY.PROPERTY=VALUE`` as an edit; ConfigError saying the shape otherwise."""
    left, eq, value = text.partition("=")
    entity, dot, prop = left.strip().partition(".")
    if not (eq and dot and entity and prop.strip() and value.strip()):
        raise ConfigError(f"--set {text!r}: give ENTITY.PROPERTY=VALUE, e.g. --set sedan1.brake_lights=broken")
    return Edit(op="set", entity=entity.strip(), property=prop.strip(), value=value.strip())


def cast_of(scenario: Scenario) -> list[Any]:
    """The scenario's cast: its entities but the robot, in order."""
    return [e for e in scenario.entities if not e.is_robot]


def context_of(scenario: Scenario, db: AssetDatabase) -> list[Any]:
    """The cast a question or a proposal may change: its entities but the robot, the objects of
    the robot's own task (the door it opens) and fixtures the database does not hold (the table
    the scene stands on), in order."""
    own = domains.make(scenario.domain).own_objects(scenario.behavior)
    return [e for e in cast_of(scenario) if e.asset in db.assets and e.asset not in own]


def cast_lines(scenario: Scenario, db: AssetDatabase) -> list[str]:
    """The cast a proposal may change (:func:`context_of`), for a prompt, one line each."""
    out = []
    for e in context_of(scenario, db):
        props = ", ".join(f"{k} = {v}" for k, v in e.properties.items())
        out.append(f"- {e.name}: a {e.asset.replace('_', ' ')}, {e.behavior or 'stationary'}"
                   + (f" ({props})" if props else ""))
    return out


def actual_values(entity: Any) -> dict[str, str]:
    """What the original scenario's entity had: its behavior, states and behavior parameters."""
    out = {k: str(v) for k, v in entity.behavior_params.items() if isinstance(v, (str, int, float))}
    out.update({k: str(v) for k, v in entity.properties.items()})
    if entity.behavior:
        out["behavior"] = entity.behavior
    return out


def path_pairs(scenario: Scenario, path: CausePath) -> dict[str, int]:
    """Scenario entity name -> index of its path entity (same asset, in order)."""
    used: set[int] = set()
    out: dict[str, int] = {}
    for e in cast_of(scenario):
        for i, pe in enumerate(path.entities):
            if i not in used and pe.asset == e.asset:
                out[e.name] = i
                used.add(i)
                break
    return out


def apply_edits(scenario: Scenario, path: CausePath, edits: list[Edit], db: AssetDatabase,
                *, robot: tuple[str, ...] = ()) -> CausePath:
    """The counterfactual's cause path: ``path`` with every entity pinned to the values the
    original ``scenario`` had, then ``edits`` applied. ConfigError naming what is wrong (an
    entity not in the chain, a property or value the asset does not have)."""
    from regen.core.graph import PathEntity

    pairs = path_pairs(scenario, path)
    by_name = {e.name: e for e in cast_of(scenario)}
    entities = [pe.model_copy(deep=True) for pe in path.entities]
    for name, i in pairs.items():  # unchanged parts kept: the original's own values
        actual = actual_values(by_name[name])
        for prop, values in entities[i].properties.items():
            if actual.get(prop) in values:
                entities[i].properties[prop] = [actual[prop]]
            elif len(values) > 1:
                same = [v for v in values if v in actual.values()]
                entities[i].properties[prop] = same[:1] or values
        if "behavior" in actual and "behavior" not in entities[i].properties:
            entities[i].properties["behavior"] = [actual["behavior"]]
    events = list(path.events)
    removed: set[int] = set()
    listing = ", ".join(pairs) or "none"
    for edit in edits:
        if edit.op in ("set", "remove"):
            if edit.entity not in pairs:
                raise ConfigError(f"{edit.describe()}: {edit.entity!r} is not an entity of the cause chain "
                                  f"(its entities: {listing})")
            i = pairs[edit.entity]
        if edit.op == "remove":
            removed.add(i)
        elif edit.op == "set":
            asset = entities[i].asset
            props = db.parameters_of(asset)
            if edit.property not in props:
                raise ConfigError(f"{edit.describe()}: a {asset} has no property {edit.property!r} "
                                  f"(it has: {', '.join(props)})")
            allowed = db.property_candidates(asset, edit.property) if edit.property in db.properties or \
                edit.property == "behavior" else None
            if allowed is not None and edit.value not in allowed:
                raise ConfigError(f"{edit.describe()}: {edit.value!r} is not a value of {edit.property} for a "
                                  f"{asset} (choose one of: {', '.join(allowed)})")
            entities[i].properties[edit.property] = [str(edit.value)]
            before, after = entities[i].event, _reworded(entities[i].event, asset, edit, db)
            events = [after if ev == before else ev for ev in events]
            for pe in entities:  # the entities of the reworded event follow it
                if pe.event == before:
                    pe.event = after
        else:
            text = (edit.text or "").strip()
            if not text:
                example = domains.backend_class(scenario.domain).wording.add_example
                raise ConfigError("--add needs a cause text" + (f", e.g. --add '{example}'" if example else ""))
            named = db.named_assets(text, robot=robot)
            if not named:
                some = ", ".join(f"'a {a.replace('_', ' ')}'" for a in list(db.assets)[:3])
                raise ConfigError(f"add cause '{text}': its words name no asset of the {db.name} database; "
                                  f"name one (e.g. {some}; `regen assets {scenario.domain}` lists them)")
            events.insert(0, text)
            # the states and motion its words name bind it, as they bind a graph's entity
            # ("a traffic light turns red": light_state = turns_red)
            entities += [PathEntity(asset=a, event=text, properties={
                p: [hit[0]] for p in db.parameters_of(a) if (hit := db.named_state(a, p, text)) is not None})
                for a in named]
    kept = [pe for i, pe in enumerate(entities) if i not in removed]
    return path.model_copy(update={"events": events, "entities": kept})


def _reworded(event: str, asset: str, edit: Edit, db: AssetDatabase) -> str:
    """The cause text after a ``set`` edit: the words that named the old state replaced by words
    for the new one ('brake lights on' -> 'broken brake lights'), else those words appended, so
    that the counterfactual's title says what it shows (its fidelity is checked like any other)."""
    prop, value = str(edit.property), str(edit.value)
    spec = db.properties.get(prop)
    phrases = list((spec.named_by or {}).get(value, [])) if spec is not None else []
    new = phrases[0] if phrases else f"{(spec.description if spec is not None else prop)} {value}".strip()
    old = db.named_states(asset, prop, event) if prop in db.properties else {}
    if old:
        out = event
        for phrase in old.values():
            # the new words in the old words' form where there are some ('turns red' -> 'turns green')
            head = phrase.split()[0].lower()
            alike = next((p for p in phrases if p.split()[0].lower() == head), new)
            out = re.sub(re.escape(phrase), alike, out, flags=re.IGNORECASE)
        return out
    return f"{event} ({new})" if new.lower() not in event.lower() else event


def ask_edits(scenario: Scenario, question: str, llm: LLM, db: AssetDatabase) -> list[Edit]:
    """The model's edits for a what-if question about ``scenario`` (validated, not applied)."""
    from regen.templates import render

    cast = []
    for e in context_of(scenario, db):
        values = {p: db.property_candidates(e.asset, p) for p in db.parameters_of(e.asset)
                  if p in db.properties or p == "behavior"}
        have = actual_values(e)
        cast.append({"name": e.name, "asset": e.asset,
                     "properties": {p: {"now": have.get(p), "values": v} for p, v in values.items() if v}})
    wording = domains.backend_class(scenario.domain).wording
    prompt = render("regen.whatif", "ask", question=question, cause=scenario.causal_graph[0],
                    cast=json.dumps(cast, indent=1), examples=wording.whatif_examples,
                    add_example=wording.add_example)
    got = llm.ask(prompt, Edits, purpose="whatif")
    return list(got.value.edits)


__all__ = ["Edit", "Edits", "actual_values", "apply_edits", "ask_edits", "cast_lines", "cast_of", "context_of", "parse_set",
           "path_pairs"]
