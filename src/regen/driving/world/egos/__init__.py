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
from regen.driving.world.egos.registry import (
    EGO_TEMPLATES,
    collect,
    match_template,
    on_junction_map,
    template_for,
)

__all__ = ["EGO_SIZE", "EGO_TEMPLATES", "JUNCTION_CX", "MAX_ACCEL", "MAX_BRAKE", "EgoTemplate", "Frame", "arc",
           "collect", "match_template", "on_junction_map", "stop_distance", "template_for"]
