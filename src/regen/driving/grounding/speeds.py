"""The speed classes an actor can start with, for the ego's behavior: solved, not guessed.

A car ahead in the ego's lane, before an ego that stops, brakes first and so drives at least as
fast as the ego; the same car in the next lane may be slow, and one behind the ego follows at
its speed. Expansion offers the property judge only the (start place, speed class) pairs the
placement model (:func:`~regen.driving.grounding.placement.solve`) can solve for that actor
alone with the ego, so the graph never binds a pair that grounding cannot honor ('the front car
with broken brake lights stops' was chosen 'slow' ahead of an ego at 10 m/s: unsatisfiable).

Imports: the driving world and this room's placement and map rules.
"""

from __future__ import annotations

from functools import lru_cache

from regen.driving.grounding.placement import solve
from regen.driving.grounding.rules import choose_map
from regen.driving.world.actors import ActorSpec, RoleChoice
from regen.driving.world.egos import EgoTemplate
from regen.errors import GroundingError

PROBE_TIME_LIMIT = 0.5  # [s] of solver work per solve (regen.cpsat); the single-actor models take milliseconds


@lru_cache(maxsize=4096)
def solvable_speeds(template: EgoTemplate, asset: str, primitive: str, start: str,
                    speeds: tuple[str, ...], size: tuple[float, float, float],
                    properties: tuple[tuple[str, str], ...] = ()) -> tuple[str, ...]:
    """The classes of ``speeds`` with which ``asset`` making ``primitive`` from ``start`` can be
    placed around the ego of ``template`` (on the map grounding would choose for it). All of
    ``speeds`` where none can (the actor needs others to be placed: no restriction to offer) or
    where no map hosts it (the start places are filtered elsewhere)."""
    role = RoleChoice(name="probe1", asset=asset, primitive=primitive, location=start,
                      speed_class=speeds[0] if speeds else "moderate", properties=dict(properties))
    try:
        t = choose_map(template, [role])
    except GroundingError:
        return speeds
    ok = tuple(sp for sp in speeds
               if solve(t, [ActorSpec(name="probe1", asset=asset, primitive=primitive, location=start,
                                      speed_class=sp, properties=dict(properties), size=size)],
                        time_limit=PROBE_TIME_LIMIT, explain=False).report.status in ("optimal", "feasible"))
    return ok or speeds


__all__ = ["solvable_speeds"]
