"""The search space of ``regen falsify``: the edits of one verified scenario's causes.

A single edit is one of the what-if edits (:class:`regen.whatif.Edit`):

- ``set``: a context entity's property to each other value the asset database allows (the
  cast and the values exactly as :func:`regen.whatif.ask_edits` offers them to a model);
- ``remove``: a context entity leaves the scene;
- ``add``: a cause the graph's expansion proposed for the same behavior, that is, another
  root-cause event of ``graph.json`` (not this scenario's chain) whose words name an asset.

The singles are ordered deterministically and spread over what they touch (round-robin over
the groups: the graph's causes, each entity's removal, each entity's property), so a small
budget samples every part of the cast before it tries a second value of one property. Two
singles combine into a pair when they touch different things (:func:`compatible`).
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Iterable, Sequence
from typing import TYPE_CHECKING, Any

from regen.whatif import Edit, actual_values, context_of, path_pairs

if TYPE_CHECKING:
    from regen.assets.database import AssetDatabase
    from regen.core.graph import CausePath, ScenarioGraph
    from regen.core.scenario import Scenario


def edit_key(edit: Edit) -> str:
    """One edit as a stable text (its fields, sorted)."""
    return json.dumps(edit.model_dump(), sort_keys=True)


def canonical(edits: Iterable[Edit]) -> list[Edit]:
    """The edits of a candidate in one fixed order (by :func:`edit_key`), duplicates dropped:
    the same set of edits is the same candidate whatever order it was made in."""
    by_key = {edit_key(e): e for e in edits}
    return [by_key[k] for k in sorted(by_key)]


def candidate_id(scenario: str, edits: Sequence[Edit]) -> str:
    """A short stable id of a candidate: a hash of the source scenario's folder name and its
    edits as a set (``regen.whatif.run.folder_name``'s idea, without the name: the folder sits
    in ``candidates/``)."""
    key = json.dumps([scenario, [edit_key(e) for e in canonical(edits)]])
    return hashlib.sha1(key.encode()).hexdigest()[:10]


def current_values(entity: Any, path_entity: Any | None = None) -> dict[str, str]:
    """What a scenario entity has now, per property: the cause path's single values (its start
    place, say), then what the scenario has (:func:`regen.whatif.actual_values`: behavior,
    states and behavior parameters)."""
    out: dict[str, str] = {}
    if path_entity is not None:
        out.update({k: v[0] for k, v in path_entity.properties.items() if len(v) == 1})
    return {**out, **actual_values(entity)}


def _path_entities(scenario: Scenario, path: CausePath) -> dict[str, Any]:
    """Scenario entity name -> its cause path entity, paired as apply_edits pairs them."""
    return {name: path.entities[i] for name, i in path_pairs(scenario, path).items()}


def root_causes(graph: ScenarioGraph | None, chain: Sequence[str]) -> list[str]:
    """The accepted root-cause events of the graph (no accepted cause before them), the
    behavior and ``chain``'s events left out, sorted by label."""
    if graph is None:
        return []
    accepted = {n.id for n in graph.events("accepted")}
    caused = {e.target for e in graph.edges if e.status == "accepted" and e.kind == "causes"
              and e.source in accepted}
    skip = {" ".join(t.lower().split()) for t in chain}
    labels = {graph.nodes[n].label for n in accepted if n != graph.root and n not in caused}
    return sorted(t for t in labels if " ".join(t.lower().split()) not in skip)


def single_edits(scenario: Scenario, path: CausePath, db: AssetDatabase, causes: Sequence[str], *,
                 robot: Sequence[str] = (), own: frozenset[str] = frozenset()) -> list[Edit]:
    """Every single edit of ``scenario``, in the search's order (see the module docstring).
    ``causes``: texts to add (:func:`root_causes`); those whose words name no asset
    (``db.named_assets``, the robot's words and ``own`` task objects excluded) are left out."""
    groups: list[list[Edit]] = []
    adds = [Edit(op="add", text=t) for t in causes if db.named_assets(t, robot=tuple(robot), own=own)]
    if adds:
        groups.append(adds)
    cast = context_of(scenario, db)
    groups += [[Edit(op="remove", entity=e.name)] for e in cast]
    paired = _path_entities(scenario, path)
    for e in cast:
        now = current_values(e, paired.get(e.name))
        for prop in db.parameters_of(e.asset):
            if prop not in db.properties and prop != "behavior":
                continue
            values = db.property_candidates(e.asset, prop) or []
            have = now.get(prop)
            if have is None:  # recorded under another name (a start place as 'location'): the one value
                hits = [v for v in values if v in now.values()]  # that the entity holds, as apply_edits pins it
                have = hits[0] if len(hits) == 1 else None
            other = [v for v in values if v != have]
            if other:
                groups.append([Edit(op="set", entity=e.name, property=prop, value=v) for v in other])
    out: list[Edit] = []
    for k in range(max((len(g) for g in groups), default=0)):
        out += [g[k] for g in groups if k < len(g)]
    return out


def compatible(a: Edit, b: Edit) -> bool:
    """Whether two single edits make a pair: they touch different things (not one property
    twice, nor an entity that the other removes), and are not the same edit."""
    if edit_key(a) == edit_key(b):
        return False
    if a.op == "add" or b.op == "add":
        return True
    if a.op == "set" and b.op == "set":
        return (a.entity, a.property) != (b.entity, b.property)
    return a.entity != b.entity  # a removal and anything else on the same entity clash


__all__ = ["candidate_id", "canonical", "compatible", "current_values", "edit_key", "root_causes",
           "single_edits"]
