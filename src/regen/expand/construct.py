"""Edge construction as ``regen eval --edges`` asks for it: the accepted subset of a labeled
source's candidates, decided by expansion's own calls and rules (one path)."""

from __future__ import annotations

from regen.assets.database import AssetDatabase
from regen.core.behavior import Behavior
from regen.errors import ConfigError
from regen.expand.edges import Domain, domain_view, judge_events, ruled_out, select_entities
from regen.expand.properties import named_states, select_properties
from regen.llm.client import LLM


def judge_candidates(llm: LLM, kind: str, source: str, candidates: list[str], *,
                     domain: Domain, context: list[str] | None = None,
                     database: AssetDatabase | None = None) -> set[str]:
    """Edge construction for evaluation: the accepted subset of ``candidates`` for ``source``.

    ``kind`` is 'event->event', 'entity->event' or 'property->entity' (for the latter, ``source``
    is the entity's asset id, ``candidates`` are 'property: value' and ``context`` the event
    chain, event first).
    """
    chain = [source, *(context or [])]
    domain = domain_view(domain)
    if kind == "event->event":  # as expansion decides: the judge, then the rules (ruled_out)
        return {c for c in judge_events(llm, domain, chain, candidates).accepted
                if ruled_out(domain, c, source) is None}
    if kind == "entity->event":
        db = database or domain.database()
        return {a for a in select_entities(llm, db, domain, chain).accepted if a in candidates}
    if kind == "property->entity":
        # as expansion asks (one call per entity, one consistent value per property), over the
        # labeled candidates ("property: value"): the properties they name, with those values
        db = database or domain.database()
        entity = source.strip()
        if entity not in db.assets:
            raise ConfigError(f"{entity!r} is not an asset of the {domain.name} database")
        asked: dict[str, list[str]] = {}
        for c in candidates:
            prop, sep, value = c.partition(":")
            if not sep or prop.strip() not in db.properties:
                raise ConfigError(f"property candidate {c!r}: write 'property: value' with a property "
                                  f"of the {domain.name} database")
            asked.setdefault(prop.strip(), []).append(value.strip())
        options = {p: (db.properties[p].description, v) for p, v in asked.items()}
        event = (context or [entity])[0]
        behavior = Behavior(text=context[-1], domain=domain.name) if context else None
        judged, _ = select_properties(llm, domain, context or [entity], event, entity, options,
                                      domain.property_choices(entity, behavior),
                                      named_states(db, entity, event, options, domain.own_objects(behavior)))
        return {f"{p}: {v}" for p, j in judged.items() for v in j.accepted}
    raise ValueError(f"unknown edge kind {kind!r}; use event->event, entity->event or property->entity")
