"""The ego behaviors of the paper (3.1): one typed spec (:class:`~regen.driving.world.egos.base.EgoTemplate`)
per module of this package, collected into one registry.

Every public module here defines ``TEMPLATE``, whose id is the module's name. Matching a text to a
template is keyword based (:func:`match_template`): the templates' keyword rules are tried in
their ``match_rank`` order (most specific first), and the first whose every group has a word in
the text wins:

==========================  =============================================================
template id                 keywords (one of each group, case-insensitive word starts)
==========================  =============================================================
stop_in_intersection        stop | halt | brake, and intersection | junction | crossroad
stop_after_turn             stop | halt | brake, and turn
change_lane                 lane, and chang | switch | merge
slow_down                   slow | decelerat
stop_abruptly               stop | brake | halt
drive_forward               driv | go | start | accelerat | forward | move
==========================  =============================================================

To add a template: write ``<id>.py`` here with its subclass and ``TEMPLATE``; the conformance
test (``tests/driving/world/test_egos.py``) checks it against the predicates, the rule FSM and
the maps. Imports: the rest of ``world`` and the shared core.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from types import MappingProxyType

from regen.driving.world.egos.base import (
    EGO_SIZE,
    JUNCTION_CX,
    MAX_ACCEL,
    MAX_BRAKE,
    EgoTemplate,
    Frame,
    arc,
    stop_distance,
)
from regen.driving.world.specs import one_per_module
from regen.errors import ConfigError


def _collect() -> Mapping[str, EgoTemplate]:
    found: list[EgoTemplate] = one_per_module(__name__, __path__, "TEMPLATE", "id", "ego template")  # type: ignore[assignment]
    return MappingProxyType({t.id: t for t in sorted(found, key=lambda t: (t.rank, t.id))})


EGO_TEMPLATES: Mapping[str, EgoTemplate] = _collect()


def match_template(text: str) -> str:
    """The ego template id for a behavior text (keyword rules above); ConfigError if none."""
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


__all__ = ["EGO_SIZE", "EGO_TEMPLATES", "JUNCTION_CX", "MAX_ACCEL", "MAX_BRAKE", "EgoTemplate", "Frame", "arc",
           "match_template", "on_junction_map", "stop_distance", "template_for"]
