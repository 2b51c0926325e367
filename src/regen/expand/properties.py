"""Property edges (paper 2.1, phase 3): the values each chosen entity starts with.

The database offers each property's states (free-valued ones, such as places, are proposed by
the model first); a state the event's words name is the only offer; one model call then picks
one consistent value per property, after a sentence on the entity's role.
"""

from __future__ import annotations

from collections.abc import Collection
from typing import TYPE_CHECKING, Any, Union, get_args

from pydantic import Field, create_model

from regen.assets.database import AssetDatabase
from regen.core.base import Answer
from regen.core.words import has_phrase, lowered, name_words
from regen.expand.choices import choice_models, only_names
from regen.expand.edges import Domain, Judged, domain_view, render_prompt
from regen.llm.client import LLM

if TYPE_CHECKING:
    from regen.contract import PropertyChoices


def propose_values(llm: LLM, domain: Domain, chain: list[str], event: str, entity: str,
                   properties: list[tuple[str, str]], *, max_values: int = 3) -> tuple[dict[str, list[str]], str]:
    """Candidate values for properties the database does not enumerate (locations)."""
    domain = domain_view(domain)
    fields: dict[str, Any] = {p: (list[str], Field(default_factory=list, description=d))
                              for p, d in properties}
    schema = create_model("FreeValues", __base__=Answer, **fields)
    prompt = "\n\n".join(
        render_prompt("property_proposal", domain, chain=chain, event=event, entity=entity,
                      property=p, description=d, max_values=max_values).rsplit("\n\nAnswer as JSON", 1)[0]
        for p, d in properties)
    example = "{" + ", ".join(f'"{p}": ["...", "..."]' for p, _ in properties) + "}"
    prompt += f"\n\nAnswer as JSON: {example}"
    got = llm.ask(prompt, schema, purpose="property_proposal", system=domain.system)
    values = {p: [" ".join(v.split()) for v in getattr(got.value, p) if v and v.strip()][:max_values]
              for p, _ in properties}
    return values, got.call_id


def property_options(db: AssetDatabase, asset: str, proposed: dict[str, list[str]]
                     ) -> dict[str, tuple[str, list[str]]]:
    """What the property judge chooses from for ``asset``: each property's description and
    values (the database's states, or for free properties such as locations the ``proposed``
    values); properties without values are left out."""
    options: dict[str, tuple[str, list[str]]] = {}
    for p in db.parameters_of(asset):
        values = db.property_candidates(asset, p)
        values = proposed.get(p, []) if values is None else values
        if values:
            options[p] = (db.properties[p].description, list(values))
    return options


#: Words of a place that say where, not what: left out when a place's own words are compared.
_WHERE = frozenset({"on", "in", "inside", "into", "onto", "near", "next", "to", "by", "beside", "at",
                    "under", "underneath", "below", "above", "over", "behind", "front", "of", "left",
                    "right", "top", "outside", "out", "reach", "close", "from", "against", "between",
                    "around", "along", "across", "up", "down", "off", "middle", "edge", "corner", "side"})

#: Phrases that say the entity has still to go somewhere: a place after one is where it goes,
#: not where it starts ("the milk has to go back into the fridge").
_STILL_TO_GO = ("go back", "goes back", "put away", "be put", "be stored", "be chilled", "needs chilling",
               "need chilling", "be refrigerated", "be frozen", "be kept cold", "has to go", "have to go",
               "must go", "needs to go", "need to go", "belongs in", "belong in", "be returned", "be tidied")


def _place_words(value: str) -> list[str]:
    return [w for w in name_words(value) if w not in _WHERE]


def _named_place(values: list[str], event: str, own: frozenset[str]) -> tuple[str, str] | None:
    """(place, phrase) of the one offered place the event names: the one it says whole, else the
    one whose own words it uses ("drying next to the sink": "on the drying rack"). Where the
    event says the entity has still to go, a place it says after that, or one in the object the
    task acts on, is where it goes, so the start is the one other place left."""
    low, words = lowered(event), name_words(event)
    goes = next((g for g in _STILL_TO_GO if has_phrase(words, name_words(g))), None)
    if goes is not None:
        after = set(name_words(low.split(goes, 1)[1])) if goes in low else set()
        away = after | {w for o in own for w in name_words(o)}
        left = [v for v in values if not set(_place_words(v)) & away]
        return (left[0], goes) if len(left) == 1 and len(left) < len(values) else None
    said = [v for v in values if has_phrase(words, name_words(v))]
    if len(said) == 1:
        return said[0], said[0]
    if said:
        return None
    shared = {v: [w for w in _place_words(v) if w in words] for v in values}
    used = [v for v, ws in shared.items() if ws]
    return (used[0], " ".join(shared[used[0]])) if len(used) == 1 else None


def named_states(db: AssetDatabase, asset: str, event: str, options: dict[str, tuple[str, list[str]]],
                 own: frozenset[str] = frozenset()) -> dict[str, tuple[str, str]]:
    """Property -> (state, phrase) for the offered properties whose state ``event``'s words name
    ("the light turns red": light_state = turns_red), so the judge cannot contradict the event;
    a free-valued one (a place) as :func:`_named_place` finds it, with ``own`` the objects the
    task acts on (``DomainBackend.own_objects``)."""
    out = {}
    for p, (_, values) in options.items():
        if p in db.properties and db.properties[p].states is None:
            place = _named_place(values, event, own)
            if place is not None:
                out[p] = place
            continue
        named = db.named_state(asset, p, event)
        if named is not None and named[0] in values:
            out[p] = named
    return out


def select_properties(llm: LLM, domain: Domain, chain: list[str], event: str, entity: str,
                      options: dict[str, tuple[str, list[str]]],
                      choices: PropertyChoices | None = None,
                      named: dict[str, tuple[str, str]] | None = None) -> tuple[dict[str, Judged], str]:
    """For each property (name -> (description, candidate values)) the one value that supports
    the entity's role: the graph's binding choice, so exactly one per property that applies.

    The schema asks for the role sentence first and allows only offered values; with
    ``choices`` (the domain's dependent properties) only consistent combinations, so the model
    states what the entity does, then picks values that agree with each other. A property that
    does not apply to the chosen key value (a stationary actor's speed) gets no value. A state
    the event's words name (``named``, :func:`named_states`) is the property's only offer; the
    values it rules out are kept in ``Judged.ruled`` with the phrase.
    """
    domain = domain_view(domain)
    ruled: dict[str, dict[str, str]] = {}
    said: dict[str, str] = {}  # property -> why the event's words decide it
    for p, (state, phrase) in (named or {}).items():
        desc, values = options[p]
        said[p] = f'the event says "{phrase}", which names {p} = {state}'
        ruled[p] = {v: said[p] for v in values if v != state}
        options = {**options, p: (desc, [state])}
    variants = choice_models(options, choices, frozenset(said))
    if len(variants) == 1:  # the prompt offers what the schema allows (a named behavior's starts)
        fields = variants[0].model_fields
        options = {p: (d, list(get_args(fields[p].annotation))) for p, (d, _) in options.items() if p in fields}
    if len(variants) == 1 and all(len(v) == 1 for _, v in options.values()):
        return _decided(options, said, ruled), ""
    choice_type = variants[0] if len(variants) == 1 else Union[tuple(variants)]  # noqa: UP007
    schema = create_model("PropertyValues", __base__=Answer, role=(str, ...), choice=(choice_type, ...))
    rules = []
    if choices is not None and choices.key is not None and len(variants) > 1:
        key = choices.key
        restricted = choices.dependent()
        for value in choices.allowed:
            for alt in choices.alternatives(value):
                if value in options[key][1] and alt is not None:
                    parts = [f"{p} one of {' | '.join(v)}" for p, v in alt.items()]
                    parts += [f"no {p}" for p in sorted(restricted) if p not in alt and p in options]
                    rules.append((value, "; ".join(parts) or "nothing else"))
    example = ", ".join(f'"{p}": "<one value>"' for p in options)

    def ask(retry: str | None, refused: tuple[str, str, list[str]] | None = None, answer: type = schema):
        prompt = render_prompt("property_edges", domain, chain=chain, event=event, entity=entity,
                               properties=[(p, d, v) for p, (d, v) in options.items()],
                               key=choices.key if rules else None, rules=rules, robot=domain.robot,
                               retry=retry, refused=refused)
        prompt += ': {"role": "<what it does>", "choice": {' + example + "}}"
        return llm.ask(prompt, answer, purpose="property_edges", system=domain.system)

    got = ask(None)
    role = " ".join(got.value.role.split())
    if only_names(role, options):  # "drive_forward (siren = off)" says no role: asked once more
        got = ask(role)
        role = " ".join(got.value.role.split())
    picked = got.value.choice.model_dump()
    key = choices.key if choices is not None else None
    narrow = (_possible(variants, key, choices.allowed) if choices is not None and key in options
              and picked.get(key) not in (None, *choices.allowed) else None)
    if narrow is not None:
        # a key value the domain cannot simulate here (a car turning at a junction the ego never
        # meets): the first schema leaves such values free (it keys the cached answers), so the
        # model is told and asked once more with a schema of the possible values only
        got = ask(None, refused=(key, picked[key], narrow[1]), answer=narrow[0])
        role = " ".join(got.value.role.split())
        picked = got.value.choice.model_dump()
    out: dict[str, Judged] = {}
    for p, (_, values) in options.items():
        j = Judged(call_id=got.call_id)
        chosen = picked.get(p)
        if chosen is not None:
            j.accepted[chosen] = f"{role} ({p} = {chosen})" if role else "supports the entity's role"
        why = (f"not chosen by the model (it chose {chosen})" if chosen is not None
               else f"does not apply with {key} = {picked.get(key)}")
        j.rejected.update({v: why for v in values if v != chosen})
        j.ruled.update(ruled.get(p, {}))
        out[p] = j
    return out, got.call_id


def _possible(variants: list[Any], key: str, allowed: Collection[str | None]) -> tuple[type, list[str]] | None:
    """The answer schema of the ``variants`` whose ``key`` value is ``allowed``, and those values
    (None when no variant's is)."""
    possible = [v for v in variants if get_args(v.model_fields[key].annotation)[0] in allowed]
    if not possible:
        return None
    choice = possible[0] if len(possible) == 1 else Union[tuple(possible)]  # noqa: UP007
    schema = create_model("PropertyValues", __base__=Answer, role=(str, ...), choice=(choice, ...))
    return schema, list(dict.fromkeys(get_args(v.model_fields[key].annotation)[0] for v in possible))


def _decided(options: dict[str, tuple[str, list[str]]], said: dict[str, str],
             ruled: dict[str, dict[str, str]]) -> dict[str, Judged]:
    """Every property has one value left (named by the event, ``said``, or the only one
    offered): no call; each value is accepted as decided by the database (``Judged.named``)."""
    out = {}
    for p, (_, (value,)) in options.items():
        why = said.get(p, f"the only value of {p} offered for this entity")
        out[p] = Judged(call_id="", accepted={value: why}, named={value: why}, ruled=dict(ruled.get(p, {})))
    return out
