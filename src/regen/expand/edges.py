"""Node proposal and edge construction: the model calls of graph expansion (paper 2.1).

Each function makes one model call and returns plain data plus the call id, so the caller can
record who proposed, accepted or rejected what. Edge construction judges all candidates of one
source node in one call, not pairwise.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from functools import lru_cache
from typing import Any

from pydantic import Field, create_model

from regen.assets.database import MATCH_THRESHOLD, AssetDatabase, name_words
from regen.core.base import Answer
from regen.errors import ConfigError
from regen.expand.answers import EdgeJudgement, EntitySelection, EventProposal
from regen.expand.dedupe import normalize, similar
from regen.llm.client import LLM
from regen.prompting import render

PKG = "regen.expand"


@dataclass
class Judged:
    """The outcome of one edge-construction call."""

    call_id: str
    accepted: dict[str, str] = field(default_factory=dict)  # candidate -> reason
    rejected: dict[str, str] = field(default_factory=dict)  # candidate -> reason
    unknown: dict[str, str] = field(default_factory=dict)  # names the model gave that were not offered
    # accepted candidate -> (who matched the model's name to it: 'database' for an alias, 'rule'
    # for a similarity guess, and how)
    matched: dict[str, tuple[str, str]] = field(default_factory=dict)


def _wording(domain: str):
    from regen import domains

    return domains.backend_class(domain).wording


def _render(name: str, domain: str, **variables: object) -> str:
    """A shared prompt in the words of ``domain`` (its backend's ``wording``)."""
    return render(PKG, name, wording=_wording(domain), **variables)


def system_prompt(domain: str) -> str:
    return _render("system", domain)


def robot_word(domain: str) -> str:
    """What the domain calls the robot whose behavior is explained ('robot', 'ego-vehicle')."""
    from regen import domains

    return domains.backend_class(domain).report_hints.robot


@lru_cache(maxsize=32)
def _mechanics(domain: str, patterns: tuple[str, ...]) -> tuple[re.Pattern[str], ...]:
    out = []
    for p in patterns:
        try:
            out.append(re.compile(p))
        except re.error as exc:
            raise ConfigError(f"domain {domain!r}: Wording.mechanics pattern {p!r} is not a valid "
                              f"regular expression ({exc})") from None
    return tuple(out)


def restates_mechanics(domain: str, cause: str) -> str | None:
    """The words of ``cause`` that restate the robot's own command, programming, sensors or
    mechanics (the domain's ``Wording.mechanics``), or None for a context of the world."""
    text = " ".join(cause.lower().replace("\u2019", "'").split())
    for rx in _mechanics(domain, tuple(_wording(domain).mechanics)):
        if m := rx.search(text):
            return m.group(0).strip() or text
    return None


def _match(name: str, options: list[str]) -> str | None:
    """The option a model-written name refers to (exact, normalized, or near-duplicate)."""
    if name in options:
        return name
    n = normalize(name).replace(" ", "_")
    for o in options:
        if normalize(o).replace(" ", "_") == n:
            return o
    for o in options:
        if similar(name, o, threshold=0.9):
            return o
    return None


def propose_events(llm: LLM, domain: str, chain: list[str], *, prior: str | None = None,
                   max_causes: int = 4) -> tuple[list[str], str]:
    """Candidate causes of ``chain[0]`` (chain runs from the source node to the behavior)."""
    prompt = _render("event_proposal", domain, chain=chain, source=chain[0],
                    prior=prior, max_causes=max_causes)
    got = llm.ask(prompt, EventProposal, purpose="event_proposal", system=system_prompt(domain))
    return got.value.causes[:max_causes], got.call_id


def judge_events(llm: LLM, domain: str, chain: list[str], candidates: list[str]) -> Judged:
    """Which candidates plausibly and directly cause ``chain[0]`` (one call for all)."""
    prompt = _render("event_edges", domain, chain=chain, source=chain[0],
                    candidates=candidates)
    got = llm.ask(prompt, EdgeJudgement, purpose="event_edges", system=system_prompt(domain))
    out = Judged(call_id=got.call_id)
    for d in got.value.decisions:
        target = _match(d.candidate, candidates)
        if target is None:
            out.unknown[d.candidate] = d.reason
        elif target not in out.accepted and target not in out.rejected:
            (out.accepted if d.plausible else out.rejected)[target] = d.reason or (
                "plausible direct cause" if d.plausible else "judged implausible")
    for c in candidates:
        if c not in out.accepted and c not in out.rejected:
            out.rejected[c] = "the model gave no decision for it"
    return out


def select_entities(llm: LLM, db: AssetDatabase, domain: str, chain: list[str]) -> Judged:
    """Entities of the database directly related to the event ``chain[0]``."""
    options = db.entities()
    prompt = _render("entity_edges", domain, chain=chain, source=chain[0],
                    entities=[(a, db.assets[a].description) for a in options])
    got = llm.ask(prompt, EntitySelection, purpose="entity_edges", system=system_prompt(domain))
    out = Judged(call_id=got.call_id)
    robot = robot_word(domain)
    # words that name the robot itself ('ego' of 'ego-vehicle'): never guessed to be another asset
    own = {w for w in name_words(robot) if db.resolve(w) is None}
    for ch in got.value.entities:
        target, how = _match(ch.name, options), None
        if target is not None and normalize(ch.name).replace(" ", "_") != normalize(target).replace(" ", "_"):
            how = ("rule", f"read '{ch.name}' as asset '{target}' (nearly the same name)")
        if target is None and (target := db.resolve(ch.name)) is not None:
            how = ("database", f"resolved '{ch.name}' to asset '{target}' (one of its names in the database)")
        if target is None and own.isdisjoint(name_words(ch.name)):
            if (m := db.match(ch.name)) is not None:
                target, how = m.asset, ("rule", m.describe(ch.name))
        if target is None:
            out.unknown[ch.name] = _unknown_reason(db, ch.name, robot, own)
        elif target not in out.accepted:
            out.accepted[target] = ch.reason or "directly related"
            if how:
                out.matched[target] = how
    return out


def _unknown_reason(db: AssetDatabase, name: str, robot: str, own: set[str]) -> str:
    why = f"'{name}' is not in the {db.name} asset database"
    if not own.isdisjoint(name_words(name)):
        return why + f" (it names the {robot} itself)"
    near = db.closest(name)
    if near is not None:
        why += (f" (closest: '{near.asset}', similarity {near.similarity:.2f}, below "
                f"{MATCH_THRESHOLD:.2f})")
    return why


def propose_values(llm: LLM, domain: str, chain: list[str], event: str, entity: str,
                   properties: list[tuple[str, str]], *, max_values: int = 3) -> tuple[dict[str, list[str]], str]:
    """Candidate values for properties the database does not enumerate (locations)."""
    fields: dict[str, Any] = {p: (list[str], Field(default_factory=list, description=d))
                              for p, d in properties}
    schema = create_model("FreeValues", __base__=Answer, **fields)
    prompt = "\n\n".join(
        _render("property_proposal", domain, chain=chain, event=event, entity=entity,
               property=p, description=d, max_values=max_values).rsplit("\n\nAnswer as JSON", 1)[0]
        for p, d in properties)
    example = "{" + ", ".join(f'"{p}": ["...", "..."]' for p, _ in properties) + "}"
    prompt += f"\n\nAnswer as JSON: {example}"
    got = llm.ask(prompt, schema, purpose="property_proposal", system=system_prompt(domain))
    values = {p: [" ".join(v.split()) for v in getattr(got.value, p) if v and v.strip()][:max_values]
              for p, _ in properties}
    return values, got.call_id


def select_properties(llm: LLM, domain: str, chain: list[str], event: str, entity: str,
                      options: dict[str, tuple[str, list[str]]]) -> tuple[dict[str, Judged], str]:
    """For each property (name -> (description, candidate values)) the supporting values."""
    fields: dict[str, Any] = {p: (list[str], Field(default_factory=list)) for p in options}
    fields["reason"] = (str, "")
    schema = create_model("PropertyValues", __base__=Answer, **fields)
    prompt = _render("property_edges", domain, chain=chain, event=event, entity=entity,
                    properties=[(p, d, v) for p, (d, v) in options.items()])
    example = "{" + ", ".join(f'"{p}": ["<value>"]' for p in options) + ', "reason": "..."}'
    prompt = prompt.rsplit("\n\nAnswer as JSON", 1)[0] + f"\n\nAnswer as JSON: {example}"
    got = llm.ask(prompt, schema, purpose="property_edges", system=system_prompt(domain))
    reason = got.value.reason or "supports the entity's role"
    out: dict[str, Judged] = {}
    for p, (_, values) in options.items():
        j = Judged(call_id=got.call_id)
        for v in getattr(got.value, p):
            target = _match(v, values)
            if target is None:
                j.unknown[v] = f"not a value of {p} in the asset database or the proposed values"
            else:
                j.accepted.setdefault(target, reason)
        for v in values:
            if v not in j.accepted:
                j.rejected[v] = "not chosen by the model"
        out[p] = j
    return out, got.call_id


def judge_candidates(llm: LLM, kind: str, source: str, candidates: list[str], *,
                     domain: str, context: list[str] | None = None,
                     database: AssetDatabase | None = None) -> set[str]:
    """Edge construction for evaluation: the accepted subset of ``candidates`` for ``source``.

    ``kind`` is 'event->event', 'entity->event' or 'property->entity' (for the latter, ``source``
    is 'entity: property' and ``context`` the event chain).
    """
    chain = [source, *(context or [])]
    if kind == "event->event":
        return set(judge_events(llm, domain, chain, candidates).accepted)
    if kind == "entity->event":
        from regen import domains

        db = database or domains.make(domain).database()
        return {a for a in select_entities(llm, db, domain, chain).accepted if a in candidates}
    if kind == "property->entity":
        entity, _, prop = source.partition(":")
        prop = prop.strip() or "value"
        judged, _ = select_properties(llm, domain, context or [entity], (context or [entity])[0],
                                      entity.strip(), {prop: (prop, candidates)})
        return set(judged[prop].accepted)
    raise ValueError(f"unknown edge kind {kind!r}; use event->event, entity->event or property->entity")
