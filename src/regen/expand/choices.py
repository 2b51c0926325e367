"""The schema of a property choice: one value per property, consistent with the key property
(a behavior's start locations and speeds), and whether a role sentence says anything.

Imports: the shared core only.
"""

from __future__ import annotations

from typing import Any, Literal

from pydantic import create_model

from regen.core.base import Answer
from regen.core.words import name_words

Choices = tuple[str | None, dict[str | None, dict[str, list[str]]]]  # DomainBackend.property_choices


def choice_models(options: dict[str, tuple[str, list[str]]], choices: Choices | None) -> list[Any]:
    """One pydantic model per consistent combination family: the key property fixed to one value,
    the properties that depend on it restricted to (or, when absent, without) their allowed
    values; independent properties free. Without dependencies, one model."""
    def model(name: str, fixed: dict[str, list[str]]) -> Any:
        fields = {p: (Literal[tuple(v)], ...) for p, v in fixed.items()}
        return create_model(name, __base__=Answer, **fields)

    free = {p: list(v) for p, (_, v) in options.items()}
    if choices is not None and choices[0] is None:  # restrictions whatever the other values
        fixed = {p: [v for v in vals if v in choices[1][None].get(p, vals)] or vals
                 for p, vals in free.items()}
        return [model("Values", fixed)]
    if choices is None or choices[0] not in options:
        return [model("Values", free)]
    key, per = choices
    dependent = {p for allowed in per.values() for p in allowed}
    out = []
    for value in options[key][1]:
        allowed = per.get(value)
        fixed: dict[str, list[str]] = {key: [value]}
        for p, vals in free.items():
            if p == key:
                continue
            if p not in dependent or allowed is None:
                fixed[p] = vals
            elif p in allowed:
                fixed[p] = [v for v in vals if v in allowed[p]] or vals
        out.append(model(f"Values{len(out)}", fixed))
    return out


def only_names(role: str, options: dict[str, tuple[str, list[str]]]) -> bool:
    """Whether a role sentence says nothing beyond the names of the offered properties and
    values ("drive_forward (siren = off)"): no role for the values to agree with."""
    names = {w for p, (_, values) in options.items() for n in (p, *values) for w in name_words(n)}
    words = [w for w in name_words(role) if w not in _FILLER]
    return not words or set(words) <= names


_FILLER = frozenset({"it", "is", "are", "be", "to", "and", "at", "in", "on", "off", "with", "its", "this",
                     "that", "does", "do", "has", "ha", "entity", "=", "value"})
