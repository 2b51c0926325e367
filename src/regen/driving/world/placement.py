"""The CP-SAT placement model with named constraints, in the driving solver's integer units.

Units inside the model are integers: decimetres [dm], decimetres per second [dm/s] and
deciseconds [ds]. Every constraint a primitive requires goes behind its own enforcement literal
named ``"actor: what it requires"`` (a :class:`regen.cpsat.NamedModel`); when the model is
infeasible, its minimal conflict set names the constraints in conflict (see
:func:`regen.driving.grounding.placement.solve`).

The ego's motion is known from its template: before its event it drives at a constant speed,
so its position along the frame at time t [s] is ``s_event - v_event * (t_event - t)``.
"""

from __future__ import annotations

from typing import Any

from regen.cpsat import NamedModel
from regen.driving.world.actors import ActorSpec
from regen.driving.world.egos import EGO_SIZE, EgoTemplate
from regen.driving.world.maps import geometry

DM = 10  # decimetres per metre (and deciseconds per second)


def frame_start(ego: EgoTemplate) -> float:
    """The least offset [m] along the ego's frame where there is road: -400, or the junction's
    edge when the frame continues behind the junction into an arm the map lacks (a south-bound
    frame on the T-junction, which has no north arm)."""
    g = geometry(ego.map)
    if not g.junction:
        return -400.0
    fr = ego.frame
    behind = {(1.0, 0.0): "west", (-1.0, 0.0): "east", (0.0, -1.0): "north", (0.0, 1.0): "south"}.get(
        (round(fr.ux, 6) + 0.0, round(fr.uy, 6) + 0.0))
    return -400.0 if behind is None or behind in g.arms else -g.junction_radius


class PlacementModel(NamedModel):
    """One CP-SAT model of the actors around an ego template."""

    def __init__(self, ego: EgoTemplate):
        super().__init__()
        self.ego = ego
        self.vars: dict[str, dict[str, Any]] = {}  # actor -> parameter -> variable

    def at_least(self, a: ActorSpec, what: str, var: Any, value: float) -> None:
        """Require ``var >= value`` (``value`` in metres, seconds or m/s), named ``a: what``."""
        self.require(f"{a.name}: {what}", var >= int(value * DM))

    def at_most(self, a: ActorSpec, what: str, var: Any, value: float) -> None:
        """Require ``var <= value`` (``value`` in metres, seconds or m/s), named ``a: what``."""
        self.require(f"{a.name}: {what}", var <= int(value * DM))

    def int(self, actor: str, key: str, lo: float, hi: float, scale: int = DM) -> Any:
        """A parameter of ``actor`` between ``lo`` and ``hi`` (in metres, seconds or m/s)."""
        lo_i, hi_i = int(round(lo * scale)), int(round(hi * scale))
        if hi_i < lo_i:
            lo_i, hi_i = hi_i, lo_i
        var = self.m.NewIntVar(lo_i, hi_i, f"{actor}.{key}")
        self.vars.setdefault(actor, {})[key] = var
        return var

    def product(self, actor: str, key: str, a: Any, b: Any, bound: int) -> Any:
        """A variable equal to ``a * b``, within ``[-bound, bound]``."""
        var = self.m.NewIntVar(-bound, bound, f"{actor}.{key}")
        self.m.AddMultiplicationEquality(var, [a, b])
        self.vars.setdefault(actor, {})[key] = var
        return var

    def start(self, a: ActorSpec, speeds: tuple[float, float]) -> tuple[Any, Any]:
        """The start offset ``s`` along the ego's frame [-400, 400] m (from the junction on, where
        the map has no road behind it) and the speed ``v`` within ``speeds`` (low, high) [m/s] of
        an actor that has a place on the road."""
        return self.int(a.name, "s", frame_start(self.ego), 400.0), self.int(a.name, "v", *speeds)

    def trigger(self, a: ActorSpec) -> Any:
        """The time ``t`` [s] at which the actor does its thing with the template ego, within the
        scenario; its plan turns it into a trigger on the ego (:mod:`regen.driving.world.triggers`)."""
        return self.int(a.name, "t", 0.0, self.ego.duration)

    def ego_s(self, t: float) -> float:
        """Ego centre along the frame [m] at time t <= t_event [s]."""
        e = self.ego
        return e.s_event - e.speed_event * (e.t_event - t)

    def half(self, a: ActorSpec) -> float:
        """Centre-to-centre length [m] of the actor and the ego with their bumpers touching."""
        return (a.size[0] + EGO_SIZE[0]) / 2


__all__ = ["DM", "PlacementModel"]
