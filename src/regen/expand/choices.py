"""The schema of a property choice: one value per property, consistent with the key property
(a behavior's start locations and speeds; the domain's
:class:`~regen.contract.PropertyChoices`), and whether a role sentence says anything.

Imports: the shared core only (the contract's types for annotations).
"""

from __future__ import annotations

from functools import lru_cache
from typing import TYPE_CHECKING, Any, Literal

from pydantic import create_model

from regen.core.base import Answer
from regen.core.words import name_words

if TYPE_CHECKING:
    from regen.contract import PropertyChoices


def choice_models(options: dict[str, tuple[str, list[str]]], choices: PropertyChoices | None,
                  named: frozenset[str] = frozenset()) -> list[Any]:
    """One pydantic model per consistent combination family: the key property fixed to one value,
    the properties that depend on it restricted to (or, when absent, without) their allowed
    values; independent properties free. Without dependencies, one model. ``named``: properties
    whose value the event's words name: a key value that cannot have it is no choice ('a slow
    truck' cannot be one that brakes hard in front of the ego), unless no key value can."""
    out = _choice_models(options, choices, named)
    return out or _choice_models(options, choices, frozenset())


def _choice_models(options: dict[str, tuple[str, list[str]]], choices: PropertyChoices | None,
                   named: frozenset[str]) -> list[Any]:
    def model(name: str, fixed: dict[str, list[str]]) -> Any:
        return _values_model(name, tuple((p, tuple(v)) for p, v in fixed.items()))

    free = {p: list(v) for p, (_, v) in options.items()}
    if choices is not None and choices.key is None:  # restrictions whatever the other values
        only = choices.alternatives(None)[0] or {}
        fixed = {p: [v for v in vals if v in only.get(p, vals)] or vals for p, vals in free.items()}
        return [model("Values", fixed)]
    if choices is None or choices.key not in options:
        return [model("Values", free)]
    key = choices.key
    restricted = choices.dependent()
    out = []
    for value in options[key][1]:
        alts = choices.alternatives(value)
        kept = 0
        for i, allowed in enumerate(alts):
            fixed: dict[str, list[str]] = {key: [value]}
            for p, vals in free.items():
                if p == key:
                    continue
                if p not in restricted or allowed is None:
                    fixed[p] = vals
                elif p in allowed:
                    fixed[p] = [v for v in vals if v in allowed[p]]
            if allowed is not None and any(p in restricted and not fixed.get(p) for p in named):
                continue  # the value the words name is not one this alternative allows (or it has none)
            if any(not v for v in fixed.values()):
                # an alternative the offered values leave nothing of is no choice; if none is
                # left, the last one with what was offered (the model's values are kept)
                if len(alts) > 1 and (kept or i < len(alts) - 1):
                    continue
                fixed = {p: v or free[p] for p, v in fixed.items()}
            kept += 1
            out.append(model(f"Values{len(out)}", fixed))
    return out


@lru_cache(maxsize=512)
def _values_model(name: str, fixed: tuple[tuple[str, tuple[str, ...]], ...]) -> Any:
    """The answer model with one of ``values`` per property (in this order): made once per
    process, so that its JSON schema is too (:func:`regen.llm.client.json_schema_of`; pydantic
    makes a class and its schema in about a millisecond each, and an expansion asks for the same
    few again and again). The class is never changed after it is made."""
    return create_model(name, __base__=Answer, **{p: (Literal[v], ...) for p, v in fixed})


def only_names(role: str, options: dict[str, tuple[str, list[str]]]) -> bool:
    """Whether a role sentence says nothing beyond the names of the offered properties and
    values ("drive_forward (siren = off)"): no role for the values to agree with."""
    names = {w for p, (_, values) in options.items() for n in (p, *values) for w in name_words(n)}
    words = [w for w in name_words(role) if w not in _FILLER]
    return not words or set(words) <= names


_FILLER = frozenset({"it", "is", "are", "be", "to", "and", "at", "in", "on", "off", "with", "its", "this",
                     "that", "does", "do", "has", "ha", "entity", "=", "value"})
