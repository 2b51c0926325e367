"""The executable form of a driving scenario: per actor, a pose, a route, a speed schedule and
the trigger that starts its cause action.

Grounding solves scalar parameters (lane, offset along the road [m], speed [m/s], trigger times
[s]); each motion primitive (:mod:`regen.driving.primitives`) turns them into an
:class:`ActorPlan`, which the Scenic writer prints; its ``states`` (from
:mod:`regen.driving.properties`) carry what the Newtonian model lacks (lights, sirens, doors,
GNSS). Schedule and states are in the template ego's time; an actor with a ``trigger``
(:mod:`regen.driving.triggers`) runs them on a clock warped to when the actual ego sets the
trigger off, so its cause happens in front of any ego.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from regen.driving.triggers import Trigger

Point = tuple[float, float]  # (x, y) [m], map frame


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
    route: list[Point] = field(default_factory=list)  # waypoints to follow [m]
    # (t_from [s], target speed [m/s], brake level 0..1: >0 brakes at that level to slow down),
    # in template time (see ``trigger``)
    schedule: list[tuple[float, float, float]] = field(default_factory=list)
    # property -> [(t_from [s], value)], e.g. {'door': [(0, 'closed'), (4.2, 'open')]}
    states: dict[str, list[tuple[float, str]]] = field(default_factory=dict)
    # what starts its cause action (schedule and states run on the warped clock); None: absolute time
    trigger: Trigger | None = None
    attach_to: str | None = None  # sensors ride on this actor
    # the Scenic behavior (program.scenic.j2) that follows the route: 'FollowRoute' (cars),
    # 'WalkRoute' (pedestrians), '' (none)
    scenic_behavior: str = ""
    comment: str = ""

    @property
    def dynamic(self) -> bool:
        return bool(self.route) and bool(self.schedule)
