"""The typed spec of an ego template, and what the templates share.

An :class:`EgoTemplate` is one behavior of the ego (paper 3.1) as a route with a speed schedule:
its map, its route, its speed schedule, its *event* (the time ``t_event`` [s] at which the
behavior happens: the ego starts, brakes, changes lane) and the *frame* in which other actors
are placed (the road the ego is on at the event). Each template is a subclass, in a module of
its own, that also says what the rest of the toolkit asks of it: the words that name it, its
states in the rule-based FSM, which ego predicates can never hold for it, and what the map
around it can host. Nothing outside its module compares a template's id.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from types import MappingProxyType
from typing import ClassVar, TypeVar

from regen.core.scenario import AbstractState, PredicateCall
from regen.driving.world.maps import ARM_LENGTH, JUNCTION_RADIUS, geometry
from regen.driving.world.states import State, pred
from regen.errors import ConfigError

MAX_BRAKE = 6.8  # Newtonian full-brake deceleration [m/s^2]
MAX_ACCEL = 5.6  # Newtonian full-throttle acceleration [m/s^2]
EGO_SIZE = (4.6, 1.9, 1.5)  # length, width, height [m]
JUNCTION_CX = ARM_LENGTH + JUNCTION_RADIUS  # x of the junction centre on junction maps [m]
STOPPING = frozenset({"braking", "stopped", "slower_than", "brake_lights_on"})
E = "ego"


@dataclass(frozen=True)
class Frame:
    """A road frame: P = origin + s * u + d * n, with n the left normal of u."""

    ox: float
    oy: float
    ux: float
    uy: float
    lanes_same_direction: int  # driving lanes in the ego's direction
    lane_width: float
    sidewalk_width: float

    def point(self, s: float, d: float) -> tuple[float, float]:
        return (self.ox + s * self.ux - d * self.uy, self.oy + s * self.uy + d * self.ux)

    @property
    def heading(self) -> float:
        """Direction of travel [rad], counter-clockwise from +x."""
        return math.atan2(self.uy, self.ux)

    def lane_d(self, k: int) -> float:
        """Lateral offset [m] of lane k: 0 innermost in the ego's direction, 1 next out;
        -1 innermost oncoming lane."""
        return -(k + 0.5) * self.lane_width if k >= 0 else (-k - 0.5) * self.lane_width

    def sidewalk_d(self, side: str = "right") -> float:
        off = self.lanes_same_direction * self.lane_width + self.sidewalk_width / 2
        return -off if side == "right" else off


@dataclass(frozen=True)
class EgoTemplate:
    """One ego behavior. Instance fields are its geometry and timing; class attributes and
    methods, overridden by each template's subclass, are what grounding asks of it."""

    id: str
    description: str
    map: str
    route: tuple[tuple[float, float], ...]  # [m]
    speed0: float  # [m/s]
    schedule: tuple[tuple[float, float, float], ...]  # (t_from [s], speed [m/s], brake 0..1)
    t_event: float  # [s] when the behavior happens
    duration: float  # [s] simulated
    frame: Frame  # the road the ego is on at the event
    s_event: float  # ego centre along the frame at t_event [m]
    speed_event: float  # ego speed just before the event [m/s]
    ego_lane: int  # lane index of the ego in the frame at the event
    stops: bool = False
    s_end: float = 0.0  # where the ego is at the end [m] (frame)
    junction_maps: tuple[str, ...] = ()  # maps it can also run on (same geometry of the event)
    needs: tuple[str, ...] = field(default_factory=tuple)  # what the map must offer
    # a recorded trajectory the ego replays exactly: (x, y, heading, speed) every ``replay_dt``
    # seconds (regen.driving.world.replay); empty: the ego follows ``route`` and ``schedule``
    replay: tuple[tuple[float, float, float, float], ...] = ()
    replay_dt: float = 0.1

    # --- what each template's subclass says -------------------------------------------------
    rank: ClassVar[int] = 99  # place in listings (the paper's order)
    match_rank: ClassVar[int] = 99  # keyword rules are tried in this order; the first match wins
    keywords: ClassVar[tuple[tuple[str, ...], ...]] = ()  # one word of each group must appear
    example: ClassVar[str] = ""  # a behavior text that names this template
    # Predicates of the ego's reaction: an ego state naming one (not negated) is a reaction
    # state, and every cause stage must come before the first of them.
    reaction_predicates: ClassVar[frozenset[str]] = STOPPING
    # Ego predicates that never hold for this template -> what the reason adds (often nothing).
    never: ClassVar[Mapping[str, str]] = MappingProxyType({})
    waits_at_start: ClassVar[bool] = False  # stationary at first: a red light ahead may turn green
    #: The behavior class a reference driver must show for the cause to explain this behavior
    #: (:mod:`regen.driving.testing.causal`): 'stops', 'slows down', 'drives off', 'changes lane'.
    reaction_class: ClassVar[str] = "stops"
    passes_junction: ClassVar[str | None] = None  # why no role may need a junction, if so
    starts_elsewhere: ClassVar[str | None] = None  # why no role may start behind the ego, if so

    def ego_states(self) -> tuple[State, list[State]]:
        """(initial state, reaction states in order) of the ego in the rule-based FSM."""
        raise NotImplementedError

    def prelude(self) -> list[State]:
        """Ego states that come before the causes (a turn before the stop), each a stage."""
        return []

    def is_reaction_call(self, call: PredicateCall) -> bool:
        """Whether a (not negated) call of an ego state shows the ego reacting."""
        return call.name in self.reaction_predicates

    def is_reaction(self, state: AbstractState) -> bool:
        """Whether ``state`` is one of the ego's reaction states."""
        return state.actor == E and any(not c.negate and self.is_reaction_call(c) for c in state.all_of)

    def never_holds(self, call: PredicateCall) -> str | None:
        """Why an ego predicate never holds for this template, or None."""
        if call.name in self.never:
            return f"{call} never holds: the ego {self.description}{self.never[call.name]}"
        return None

    def on_map(self, map_name: str) -> EgoTemplate:
        """This template moved onto the approach of a junction map (same timing)."""
        if map_name == self.map:
            return self
        if map_name not in self.junction_maps:
            raise ConfigError(f"ego template {self.id!r} cannot run on map {map_name!r}")
        fr = junction_frame(map_name)
        # shift the route so that the ego stops (or its event happens) short of the junction entry
        target = -JUNCTION_RADIUS - 6.0
        shift_s = target - self.s_end if self.stops else target - 20.0 - self.s_event
        route = tuple((JUNCTION_CX + x + shift_s, fr.lane_d(0)) for x, _ in self.route
                      if JUNCTION_CX + x + shift_s > 0.5)
        return replace(self, map=map_name, frame=fr, route=route, s_event=self.s_event + shift_s,
                       s_end=self.s_end + shift_s)


def straight_frame() -> Frame:
    g = geometry("straight")
    return Frame(0.0, 0.0, 1.0, 0.0, g.lanes_per_direction, g.lane_width, g.sidewalk_width)


def junction_frame(name: str, direction: str = "east") -> Frame:
    g = geometry(name)
    if direction == "east":
        return Frame(JUNCTION_CX, 0.0, 1.0, 0.0, 1, g.lane_width, g.sidewalk_width)
    return Frame(JUNCTION_CX, 0.0, 0.0, -1.0, 1, g.lane_width, g.sidewalk_width)  # south-bound


def line(a: tuple[float, float], b: tuple[float, float], step: float = 5.0) -> list[tuple[float, float]]:
    """Points every ``step`` [m] (at most) from a to b."""
    n = max(1, int(math.hypot(b[0] - a[0], b[1] - a[1]) // step))
    return [(a[0] + (b[0] - a[0]) * i / n, a[1] + (b[1] - a[1]) * i / n) for i in range(n + 1)]


def arc(center: tuple[float, float], radius: float, a0: float, a1: float,
        step: float = 1.5) -> list[tuple[float, float]]:
    """Points on a circle arc from angle a0 to a1 [rad] about ``center``."""
    n = max(2, int(abs(a1 - a0) * radius // step))
    return [(center[0] + radius * math.cos(a0 + (a1 - a0) * i / n),
             center[1] + radius * math.sin(a0 + (a1 - a0) * i / n)) for i in range(n + 1)]


def stop_distance(v: float, decel: float = MAX_BRAKE) -> float:
    """Distance [m] to stop from speed v [m/s] at deceleration decel [m/s^2] (with 0.1 s lag)."""
    return v * v / (2 * decel) + 0.1 * v


def stopping_states(*, in_junction: bool = False) -> tuple[State, list[State]]:
    """The ego of a template that stops: driving, then braking hard, then stopped."""
    stopped = [pred("stopped", E)] + ([pred("in_junction", E)] if in_junction else [])
    return ("driving", [pred("moving", E, min_speed=3.0)]), [
        ("braking", [pred("braking", E, min_decel=4.0)]), ("stopped", stopped)]


NOT_ON_STRAIGHT = MappingProxyType({"turning": "", "changing_lane": "", "accelerating": ""})

T = TypeVar("T", bound=EgoTemplate)


def speed_change_on_straight(cls: type[T], template_id: str, description: str, *, speed: float,
                             to_speed: float, brake: float, stops: bool, after_event: float,
                             t_event: float = 6.0, duration: float = 16.0) -> T:
    """A template of the straight road (also run on the four-way map): the ego drives in the
    inner lane from 150 m before the origin at ``speed`` [m/s] and at ``t_event`` [s] changes to
    ``to_speed`` [m/s] with ``brake`` (0..1); it ends ``after_event`` [m] past where it was at
    the event."""
    fs = straight_frame()
    y0 = fs.lane_d(0)
    s_event = -150 + speed * t_event
    return cls(template_id, description, "straight", tuple(line((-150, y0), (190, y0))), speed,
               ((0.0, speed, 0.0), (t_event, to_speed, brake)), t_event, duration, fs,
               s_event, speed, 0, stops, s_event + after_event, junction_maps=("four_way",))

__all__ = ["EGO_SIZE", "JUNCTION_CX", "MAX_ACCEL", "MAX_BRAKE", "NOT_ON_STRAIGHT", "STOPPING", "E",
           "EgoTemplate", "Frame", "arc", "junction_frame", "line", "speed_change_on_straight", "stop_distance",
           "stopping_states", "straight_frame"]
