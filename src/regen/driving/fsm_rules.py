"""The rule-based FSM: a deterministic default per ego template and per actor primitive.

Used for hand-written chains, and whenever the model's FSM is unusable. Stages: (1) every
actor's initial state with the ego's initial state, (2) each cause, one stage per actor in path
order, (3) the ego's behavior states, one stage each, (4) the actors' final states together.
"""

from __future__ import annotations

from dataclasses import dataclass

from regen.core.scenario import FSM, AbstractState, PredicateCall, Stage, StateRef
from regen.driving.ego import EgoTemplate


@dataclass
class RoleChoice:
    """One actor as grounding decided it."""

    name: str
    asset: str
    primitive: str
    location: str
    speed_class: str
    properties: dict[str, str]


def P(name: str, *args: str, negate: bool = False, **params) -> PredicateCall:
    return PredicateCall(name=name, args=list(args), params=params, negate=negate)


Calls = list[PredicateCall]


def ego_states(t: EgoTemplate) -> tuple[tuple[str, Calls], list[tuple[str, Calls]]]:
    """(initial state, behavior states in order) of the ego."""
    e = "ego"
    if t.id == "drive_forward":
        return ("waiting", [P("stopped", e)]), [("driving_off", [P("moving", e, min_speed=2.0),
                                                                 P("accelerating", e)])]
    if t.id == "slow_down":
        return ("driving", [P("moving", e, min_speed=8.0)]), [
            ("slowing", [P("braking", e, min_decel=1.0)]),
            ("driving_slowly", [P("moving", e, min_speed=1.0), P("slower_than", e, max_speed=6.0)])]
    if t.id == "change_lane":
        return ("driving", [P("moving", e, min_speed=5.0), P("in_lane", e, lane=1)]), [
            ("changing_lane", [P("changing_lane", e)]),
            ("in_new_lane", [P("in_lane", e, lane=0), P("moving", e, min_speed=5.0)])]
    events: list[tuple[str, Calls]] = []
    events.append(("braking", [P("braking", e, min_decel=4.0)]))
    stopped = [P("stopped", e)]
    if t.id == "stop_in_intersection":
        stopped.append(P("in_junction", e))
    events.append(("stopped", stopped))
    return ("driving", [P("moving", e, min_speed=3.0)]), events


def actor_states(r: RoleChoice, t: EgoTemplate) -> tuple[tuple[str, Calls] | None,
                                                          tuple[str, Calls] | None,
                                                          tuple[str, Calls] | None]:
    """(initial, cause, final) states of one actor; any may be None."""
    a, e = r.name, "ego"
    props = r.properties
    asset, prim, loc = r.asset, r.primitive, r.location
    if asset == "traffic_light":
        ls = props.get("light_state", "turns_red")
        if ls == "turns_red":
            return ("green", [P("light_is", a, value="green")]), ("red", [P("light_is", a, value="red")]), None
        if ls == "red" and t.id == "drive_forward":
            return ("red", [P("light_is", a, value="red")]), ("green", [P("light_is", a, value="green")]), None
        return (f"shows_{ls}", [P("light_is", a, value=ls)]), None, None
    if asset in ("gnss", "camera"):
        return (("nominal", [P("signal_degraded", a, negate=True)]),
                ("degraded", [P("signal_degraded", a)]), None)
    init: tuple[str, Calls] | None = None
    cause: tuple[str, Calls] | None = None
    final: tuple[str, Calls] | None = None
    if prim == "stationary":
        if loc == "behind_same_lane":
            init = ("behind_ego", [P("behind", a, e)])
        elif props.get("door") == "opens":
            init = ("door_closed", [P("door_open", a, negate=True), P("ahead_of", a, e)])
            cause = ("door_open", [P("door_open", a), P("ahead_of", a, e)])
        else:
            init = ("ahead_of_ego", [P("ahead_of", a, e), P("stopped", a)])
            final = ("still_ahead", [P("ahead_of", a, e)])
    elif prim == "cross_the_road":
        init = ("waiting", [P("on_sidewalk", a)])
        cause = ("crossing", [P("on_road", a), P("moving", a, min_speed=0.3), P("ahead_of", a, e)])
    elif prim == "walk_along":
        init = ("walking", [P("moving", a, min_speed=0.3), P("on_sidewalk", a)])
        cause = ("near_ego", [P("close_to", a, e, distance=20.0)])
    elif loc in ("junction_cross_street", "junction_oncoming"):
        init = ("approaching_junction", [P("moving", a), P("in_junction", a, negate=True)])
        cause = ("in_junction", [P("in_junction", a), P("moving", a)])
    elif prim == "cut_in":
        init = ("overtaking", [P("behind", a, e), P("adjacent_lane", a, e)])
        cause = ("cut_in", [P("same_lane", a, e), P("ahead_of", a, e)])
    elif prim == "change_lane":
        init = ("ahead_in_next_lane", [P("ahead_of", a, e), P("adjacent_lane", a, e)])
        cause = ("in_ego_lane", [P("in_front", a, e, distance=40.0)])
    elif loc == "ahead_same_lane":
        if t.stops:
            init = ("leading", [P("in_front", a, e, distance=60.0), P("moving", a)])
            cause = ("braking", [P("braking", a, min_decel=3.0)])
            final = ("stopped_ahead", [P("stopped", a), P("ahead_of", a, e)])
        elif t.speed_event == 0.0:
            init = ("waiting_ahead", [P("stopped", a), P("in_front", a, e, distance=20.0)])
            cause = ("departing", [P("moving", a), P("ahead_of", a, e)])
        else:
            init = ("leading", [P("ahead_of", a, e), P("moving", a)])
            cause = ("close_ahead", [P("in_front", a, e, distance=40.0)])
    elif loc == "behind_same_lane":
        init = ("following", [P("behind", a, e), P("moving", a)])
        final = ("behind_ego", [P("behind", a, e)])
    elif loc == "behind_adjacent_lane":
        init = ("approaching", [P("behind", a, e), P("moving", a)])
        cause = ("close_behind", [P("behind", a, e), P("close_to", a, e, distance=30.0)])
        final = ("passing", [P("ahead_of", a, e), P("moving", a)])
    elif loc == "oncoming_lane":
        init = ("oncoming", [P("ahead_of", a, e), P("moving", a)])
        cause = ("close", [P("close_to", a, e, distance=25.0)])
    else:  # ahead in the adjacent lane
        init = ("ahead_in_next_lane", [P("ahead_of", a, e), P("adjacent_lane", a, e)])
    extra: Calls = []
    if props.get("siren") == "on":
        extra.append(P("siren_on", a))
    if props.get("hazard_lights") == "on":
        extra.append(P("hazard_lights_on", a))

    def add(st: tuple[str, Calls] | None) -> tuple[str, Calls] | None:
        return None if st is None else (st[0], st[1] + extra)

    return add(init), add(cause), add(final)


def rule_based_fsm(roles: list[RoleChoice], t: EgoTemplate) -> FSM:
    """The default FSM for a set of actors around an ego template."""
    states: list[AbstractState] = []
    first: list[StateRef] = []
    causes: list[Stage] = []
    finals: list[StateRef] = []
    for r in roles:
        init, cause, final = actor_states(r, t)
        for st, bucket in ((init, "i"), (cause, "c"), (final, "f")):
            if st is None:
                continue
            states.append(AbstractState(name=st[0], actor=r.name, all_of=st[1]))
            ref = StateRef(actor=r.name, state=st[0])
            if bucket == "i":
                first.append(ref)
            elif bucket == "c":
                causes.append(Stage(conditions=[ref]))
            else:
                finals.append(ref)
    (ename, ecalls), events = ego_states(t)
    states.append(AbstractState(name=ename, actor="ego", all_of=ecalls))
    stages = [Stage(conditions=first + [StateRef(actor="ego", state=ename)])]
    if t.id == "stop_after_turn":  # the turn comes before the causes of the stop
        states.append(AbstractState(name="turning", actor="ego",
                                    all_of=[P("turning", "ego"), P("moving", "ego", min_speed=2.0)]))
        stages.append(Stage(conditions=[StateRef(actor="ego", state="turning")]))
    stages += causes
    for name, calls in events:
        states.append(AbstractState(name=name, actor="ego", all_of=calls))
        stages.append(Stage(conditions=[StateRef(actor="ego", state=name)]))
    if finals:
        stages.append(Stage(conditions=finals))
    return FSM(states=states, stages=stages)
