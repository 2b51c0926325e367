"""The executable form of a driving scenario: per actor, a pose, a route, a speed schedule and
the trigger that starts its cause action.

Grounding solves scalar parameters (lane, offset along the road [m], speed [m/s], trigger times
[s]); each motion primitive (:mod:`regen.driving.primitives`) turns them into an
:class:`ActorPlan`, which the Scenic writer prints; its ``states`` (from
:mod:`regen.driving.world.properties`) carry what the Newtonian model lacks (lights, sirens, doors,
GNSS). Schedule and states are in the template ego's time; an actor with a ``trigger``
(:mod:`regen.driving.world.triggers`) runs them on a clock warped to when the actual ego sets the
trigger off, so its cause happens in front of any ego. A vehicle that changes lanes
(:class:`LaneChange`) also keeps pace with the ego until then, and lays its lane change out
from where it is when the trigger fires.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from regen.driving.world.triggers import Trigger

Point = tuple[float, float]  # (x, y) [m], map frame


@dataclass(frozen=True, kw_only=True)
class LaneChange:
    """A lane change laid out when the actor's trigger fires, from where the actor is then.

    In the frame (origin ``ox, oy`` [m], unit direction ``ux, uy``): on ``lead`` [m] in its own
    lane, over into the lane at lateral offset ``d_to`` [m] within ``length`` [m], then along
    that lane to ``ahead`` [m] past where the change starts. Until then it drives along its own lane
    keeping pace with the ego: its schedule's speeds times the ego's speed over ``ego_speed``
    (the template ego's speed [m/s]; 0: the template ego waits, no pacing), a factor it keeps
    from the firing on. For the template ego the factor is 1 and the route is its ``route``.
    """

    ox: float  # [m]
    oy: float  # [m]
    ux: float
    uy: float
    d_to: float  # [m]
    lead: float  # [m]
    length: float  # [m]
    ahead: float  # [m]
    ego_speed: float  # [m/s]

    def spec(self) -> tuple[float, ...]:
        """The numbers the Scenic program's ``FollowRoute`` takes (in field order)."""
        return (self.ox, self.oy, self.ux, self.uy, self.d_to, self.lead, self.length, self.ahead,
                self.ego_speed)

    def lane_line(self, x: float, y: float) -> list[Point]:
        """The route [m] it follows from (``x``, ``y``) [m] until its trigger fires: along its lane."""
        return [(x, y), (x + self.ahead * self.ux, y + self.ahead * self.uy)]


@dataclass
class ActorPlan:
    name: str
    asset: str
    kind: str  # 'ego', 'agent', 'object', 'sensor'
    cls: str  # Scenic class: 'Car', 'Pedestrian', 'Object' ('' for sensors: not in Scenic)
    x: float  # start [m]
    y: float  # start [m]
    heading: float  # start heading [rad], counter-clockwise from +x
    length: float  # [m]
    width: float  # [m]
    height: float  # [m]
    speed0: float = 0.0  # initial speed [m/s]
    # waypoints to follow [m] (with a ``lane_change``: its way if the ego is the template)
    route: list[Point] = field(default_factory=list)
    # (t_from [s], target speed [m/s], brake level 0..1: >0 brakes at that level to slow down),
    # in template time (see ``trigger``)
    schedule: list[tuple[float, float, float]] = field(default_factory=list)
    # property -> [(t_from [s], value)], e.g. {'door': [(0, 'closed'), (4.2, 'open')]}
    states: dict[str, list[tuple[float, str]]] = field(default_factory=dict)
    # what starts its cause action (schedule and states run on the warped clock); None: absolute time
    trigger: Trigger | None = None
    lane_change: LaneChange | None = None  # laid out when the trigger fires (None: ``route`` as is)
    attach_to: str | None = None  # sensors ride on this actor
    # the Scenic behavior (program.scenic.j2) that follows the route: 'FollowRoute' (cars),
    # 'WalkRoute' (pedestrians), '' (none)
    scenic_behavior: str = ""
    comment: str = ""
    # 'ReplayPath': the pose (x, y, heading [rad from +x], speed) at every step, set exactly
    replay: list[tuple[float, float, float, float]] = field(default_factory=list)
    # an imported cause event (regen.driving.interop.importing): after ``trigger`` fires, these poses
    # from that step on, in map coordinates or (``after_relative``) from where the actor was then
    after: list[tuple[float, float, float, float]] = field(default_factory=list)
    after_relative: bool = False
    # the ego reacts to a degraded sensor (regen.driving.world.sensing.sensing_spec), or None
    sensing: tuple | None = None

    @property
    def dynamic(self) -> bool:
        return bool(self.replay) or (bool(self.route) and bool(self.schedule))
