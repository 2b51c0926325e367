"""The typed spec of a motion primitive, and what the specs share.

A :class:`Primitive` says everything the toolkit knows about one way an actor moves: which
assets may use it, where it may start, its speed classes, which predicates can hold for it, its
CP-SAT constraints, its executable plan (which also says how Scenic drives it), its states in the
rule-based FSM and how OpenSCENARIO replays it. The registry (:mod:`regen.driving.primitives`)
collects one spec per module of this package.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

from regen.driving.world.actors import PEDESTRIAN_ASSETS, ActorSpec, RoleChoice, scenic_class
from regen.driving.world.egos import EgoTemplate
from regen.driving.world.locations import lateral_offset
from regen.driving.world.placement import PlacementModel
from regen.driving.world.plan import ActorPlan
from regen.driving.world.states import State, pred

SPEED_CLASSES = ("slow", "moderate", "fast")
# Predicates about an actor's own motion: none of them holds for an actor that does not move.
MOTION_PREDICATES = frozenset({"moving", "braking", "accelerating", "steady", "turning",
                               "changing_lane"})
LANE_CHANGE_LENGTH = 20.0  # [m] travelled during a lane change


@dataclass(frozen=True, kw_only=True)
class SpeedClasses:
    """The speed range (low, high) [m/s] of each speed class."""

    slow: tuple[float, float]  # [m/s]
    moderate: tuple[float, float]  # [m/s]
    fast: tuple[float, float]  # [m/s]

    def range(self, speed_class: str, default: str = "moderate") -> tuple[float, float]:
        """(low, high) [m/s] of ``speed_class``; of ``default`` for a class it does not know."""
        return getattr(self, speed_class if speed_class in SPEED_CLASSES else default)


VEHICLE_SPEEDS = SpeedClasses(slow=(3.0, 7.0), moderate=(7.0, 12.0), fast=(12.0, 18.0))
WALK_SPEEDS = SpeedClasses(slow=(0.8, 1.2), moderate=(1.2, 1.8), fast=(1.8, 3.0))


@dataclass(frozen=True, kw_only=True)
class RuleStates:
    """An actor's states in the rule-based FSM: before the cause, as the cause, at the end.

    ``cause`` holds the states, in order, that together show the cause playing out: its
    defining motion, not just a place (a crossing pedestrian moving in the ego's lane ahead; a
    vehicle first in the next lane ahead, then in the ego's lane). Every actor of a path has at
    least one; each becomes a stage of its own before the ego's reaction, in every driving FSM.
    """

    initial: State | None = None
    cause: tuple[State, ...] = ()
    final: State | None = None


@dataclass(frozen=True, kw_only=True)
class Placed:
    """One actor with its solved parameters: what a primitive's plan is built from."""

    actor: ActorSpec
    kind: str  # the asset database's kind: 'agent', 'object' or 'sensor'
    params: Mapping[str, float]  # solved: s [m], v [m/s], t [s], d0 [m] (those it has)
    ego: EgoTemplate

    @property
    def lateral(self) -> float:
        """Lateral offset [m] of its start location in the ego's frame."""
        a = self.actor
        return lateral_offset(self.ego, a.location, a.asset, a.size[1])

    def actor_plan(self, **fields: object) -> ActorPlan:
        """An :class:`ActorPlan` of this actor: pose, route and schedule from ``fields``."""
        a = self.actor
        length, width, height = a.size
        fields.setdefault("comment", f"{a.primitive} from {a.location}")
        return ActorPlan(name=a.name, asset=a.asset, kind=self.kind, cls=scenic_class(a.asset, self.kind),
                         length=length, width=width, height=height, **fields)  # type: ignore[arg-type]


Constrain = Callable[[PlacementModel, ActorSpec, tuple[float, float]], None]


@dataclass(frozen=True, kw_only=True)
class ClassMotion:
    """How an actor of one Scenic class moves by a primitive made for another class (a cyclist,
    a Scenic ``Car``, crossing the road as pedestrians do): its speeds and Scenic behavior."""

    speeds: SpeedClasses  # its speed classes [m/s]
    scenic_behavior: str  # the behavior of program.scenic.j2 that follows its route


@dataclass(frozen=True, kw_only=True)
class Primitive:
    """One motion primitive (or, with ``only_for``, the state switching of lights and sensors)."""

    name: str  # the id in the asset database's ``behaviors`` and in model answers
    # asset database categories whose assets may use it ('vehicles', 'pedestrians', ...); which
    # assets do is the database's ``assets.<id>.behaviors``
    users: frozenset[str]
    starts: tuple[str, ...]  # start locations it supports (regen.driving.world.locations), default first
    speeds: SpeedClasses | None  # None: the speed classes of the actor's asset (speed pinned)
    moves: bool  # False: no motion predicate ever holds for it
    leaves_line: bool = False  # it moves sideways out of its lane line: `changing_lane` can hold
    turns: bool = False  # `turning` can hold
    in_lanes: bool = False  # it drives in the lanes: `on_sidewalk` never holds
    needs_junction: bool = False  # only a junction map can host it
    # lights and sensors: the assets this spec describes, whatever primitive their role names
    only_for: frozenset[str] = frozenset()
    # how it is written out: the Scenic behavior of program.scenic.j2 that follows its route
    # ('' : it stands), and whether OpenSCENARIO replays its recorded path as a trajectory
    scenic_behavior: str = ""
    xosc_trajectory: bool = False
    # property states the motion itself implies (an emergency vehicle passing through has its
    # siren on): the graph offers only these values with this primitive
    implies: Mapping[str, str] = field(default_factory=lambda: MappingProxyType({}), hash=False, compare=False)
    # actors of other Scenic classes than its usual users, by class ('Car'): how they move by it
    # (WalkRoute takes pedestrian-only actions, so a Car follows the route with FollowRoute)
    by_class: Mapping[str, ClassMotion] = field(default_factory=lambda: MappingProxyType({}),
                                                hash=False, compare=False)
    add_constraints: Constrain  # its CP-SAT constraints (model, actor, speed range [m/s])
    build_plan: Callable[[Placed], ActorPlan]  # its executable plan from the solved parameters
    rule_states: Callable[[RoleChoice, EgoTemplate], RuleStates]  # its states in the rule FSM

    def speed_classes(self, asset: str, kind: str = "agent") -> SpeedClasses:
        """The speed classes of ``asset`` (of database ``kind``) moving by this primitive."""
        other = self.by_class.get(scenic_class(asset, kind))
        if other is not None:
            return other.speeds
        if self.speeds is not None:
            return self.speeds
        return WALK_SPEEDS if asset in PEDESTRIAN_ASSETS else VEHICLE_SPEEDS

    def scenic_behavior_of(self, cls: str) -> str:
        """The Scenic behavior that drives an actor of Scenic class ``cls`` by this primitive."""
        other = self.by_class.get(cls)
        return other.scenic_behavior if other is not None else self.scenic_behavior

    def speed_range(self, a: RoleChoice) -> tuple[float, float]:
        """(low, high) [m/s] the solver may give the actor."""
        return self.speed_classes(a.asset).range(a.speed_class)

    def constrain(self, m: PlacementModel, a: ActorSpec) -> None:
        """Add the actor's parameters and named constraints to the placement model."""
        self.add_constraints(m, a, self.speed_range(a))

    def plan(self, placed: Placed) -> ActorPlan:
        """The actor's executable plan, with the Scenic behavior that drives it."""
        plan = self.build_plan(placed)
        plan.scenic_behavior = self.scenic_behavior_of(plan.cls)
        return plan

    def never_holds(self, predicate: str, r: RoleChoice) -> str | None:
        """Why ``predicate`` about ``r`` alone never holds while it moves by this primitive, as
        'who does what' (None: it may hold; properties and speeds are checked elsewhere)."""
        if predicate in MOTION_PREDICATES and not self.moves:
            return f"{r.name} ({r.asset}) does not move"
        if predicate == "changing_lane" and not self.leaves_line:
            return f"{r.name} ({r.primitive}) keeps its line"
        if predicate == "turning" and not self.turns:
            return f"{r.name} ({r.primitive}) does not turn"
        if predicate == "on_sidewalk" and self.in_lanes:
            return f"{r.name} drives in the lanes"
        return None


@dataclass(frozen=True, kw_only=True)
class VehiclePrimitive(Primitive):
    """A primitive of vehicles that drive in the lanes (Scenic follows its route with FollowRoute)."""

    users: frozenset[str] = frozenset({"vehicles"})
    speeds: SpeedClasses | None = VEHICLE_SPEEDS
    moves: bool = True
    in_lanes: bool = True
    scenic_behavior: str = "FollowRoute"
    xosc_trajectory: bool = True


@dataclass(frozen=True, kw_only=True)
class PedestrianPrimitive(Primitive):
    """A primitive of pedestrians (Scenic walks its route with WalkRoute)."""

    users: frozenset[str] = frozenset({"pedestrians"})
    speeds: SpeedClasses | None = WALK_SPEEDS
    moves: bool = True
    scenic_behavior: str = "WalkRoute"
    xosc_trajectory: bool = True


__all__ = ["LANE_CHANGE_LENGTH", "MOTION_PREDICATES", "SPEED_CLASSES", "VEHICLE_SPEEDS", "WALK_SPEEDS",
           "ClassMotion", "PedestrianPrimitive", "Placed", "Primitive", "RuleStates", "SpeedClasses", "State",
           "VehiclePrimitive", "pred"]
