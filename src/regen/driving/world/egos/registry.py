"""The registry of the ego templates: every public module of this package defines ``TEMPLATE``,
whose id is the module's name (:data:`EGO_TEMPLATES`, in rank order); a behavior text is matched
to one by keywords (:func:`match_template`, the table in the package's docstring). This module is
private (its name starts with ``_``), so the registry does not take it for a template."""

from __future__ import annotations

import re
from collections.abc import Mapping
from pathlib import Path
from types import MappingProxyType

from regen.driving.world.egos.base import EgoTemplate
from regen.driving.world.specs import one_per_module
from regen.errors import ConfigError

PACKAGE = __name__.rpartition(".")[0]  # regen.driving.world.egos
PATH = [str(Path(__file__).parent)]  # its __path__


def collect() -> Mapping[str, EgoTemplate]:
    """Every template of this package by id, in rank order (imports every template module)."""
    found: list[EgoTemplate] = one_per_module(PACKAGE, PATH, "TEMPLATE", "id", "ego template")  # type: ignore[assignment]
    return MappingProxyType({t.id: t for t in sorted(found, key=lambda t: (t.rank, t.id))})


EGO_TEMPLATES: Mapping[str, EgoTemplate] = collect()


def match_template(text: str) -> str:
    """The ego template id for a behavior text (the package's keyword rules); ConfigError if none."""
    words = re.findall(r"[a-z]+", text.lower())
    for t in sorted(EGO_TEMPLATES.values(), key=lambda t: (t.match_rank, t.id)):
        if t.keywords and all(any(w.startswith(k) for w in words for k in group) for group in t.keywords):
            return t.id
    raise ConfigError(f"no ego template matches {text!r}; name one with ego_template= "
                      f"({', '.join(EGO_TEMPLATES)})")


def template_for(behavior_text: str, template_id: str | None = None) -> EgoTemplate:
    """The template named by ``template_id``, else the one matched from the text."""
    tid = template_id or match_template(behavior_text)
    if tid not in EGO_TEMPLATES:
        raise ConfigError(f"unknown ego template {tid!r}; choose one of: {', '.join(EGO_TEMPLATES)}")
    return EGO_TEMPLATES[tid]


def on_junction_map(t: EgoTemplate, map_name: str) -> EgoTemplate:
    """A template moved onto the approach of another map that has the geometry of its event."""
    return t.on_map(map_name)


__all__ = ["EGO_TEMPLATES", "collect", "match_template", "on_junction_map", "template_for"]
