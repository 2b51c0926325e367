"""The rule-based FSM: a deterministic default per ego template and per actor primitive.

Used for hand-written chains, and whenever the model's FSM is unusable. Stages: (1) every
actor's initial state with the ego's initial state, (2) each cause, one stage per actor in path
order, (3) the ego's behavior states, one stage each, (4) the actors' final states together.
"""

from __future__ import annotations

from regen.core.scenario import FSM, AbstractState, PredicateCall, Stage, StateRef
from regen.driving.actors import RoleChoice
from regen.driving.ego import EgoTemplate
from regen.driving.primitives import for_actor
from regen.driving.primitives.base import RuleStates, State, pred

Calls = list[PredicateCall]


def ego_states(t: EgoTemplate) -> tuple[State, list[State]]:
    """(initial state, behavior states in order) of the ego."""
    e = "ego"
    if t.id == "drive_forward":
        return ("waiting", [pred("stopped", e)]), [("driving_off", [pred("moving", e, min_speed=2.0),
                                                                    pred("accelerating", e)])]
    if t.id == "slow_down":
        return ("driving", [pred("moving", e, min_speed=8.0)]), [
            ("slowing", [pred("braking", e, min_decel=1.0)]),
            ("driving_slowly", [pred("moving", e, min_speed=1.0), pred("slower_than", e, max_speed=6.0)])]
    if t.id == "change_lane":
        return ("driving", [pred("moving", e, min_speed=5.0), pred("in_lane", e, lane=1)]), [
            ("changing_lane", [pred("changing_lane", e)]),
            ("in_new_lane", [pred("in_lane", e, lane=0), pred("moving", e, min_speed=5.0)])]
    events: list[State] = []
    events.append(("braking", [pred("braking", e, min_decel=4.0)]))
    stopped = [pred("stopped", e)]
    if t.id == "stop_in_intersection":
        stopped.append(pred("in_junction", e))
    events.append(("stopped", stopped))
    return ("driving", [pred("moving", e, min_speed=3.0)]), events


def actor_states(r: RoleChoice, t: EgoTemplate) -> RuleStates:
    """The initial, cause and final states of one actor (any may be None): those of its
    primitive, each with the states its properties show all along (siren, hazard lights)."""
    states = for_actor(r.asset, r.primitive).rule_states(r, t)
    extra: Calls = []
    if r.properties.get("siren") == "on":
        extra.append(pred("siren_on", r.name))
    if r.properties.get("hazard_lights") == "on":
        extra.append(pred("hazard_lights_on", r.name))

    def add(st: State | None) -> State | None:
        return None if st is None else (st[0], st[1] + extra)

    return RuleStates(initial=add(states.initial), cause=add(states.cause), final=add(states.final))


def rule_based_fsm(roles: list[RoleChoice], t: EgoTemplate) -> FSM:
    """The default FSM for a set of actors around an ego template."""
    states: list[AbstractState] = []
    first: list[StateRef] = []
    causes: list[Stage] = []
    finals: list[StateRef] = []
    for r in roles:
        own = actor_states(r, t)
        for st, bucket in ((own.initial, "i"), (own.cause, "c"), (own.final, "f")):
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
                                    all_of=[pred("turning", "ego"), pred("moving", "ego", min_speed=2.0)]))
        stages.append(Stage(conditions=[StateRef(actor="ego", state="turning")]))
    stages += causes
    for name, calls in events:
        states.append(AbstractState(name=name, actor="ego", all_of=calls))
        stages.append(Stage(conditions=[StateRef(actor="ego", state=name)]))
    if finals:
        stages.append(Stage(conditions=finals))
    return FSM(states=states, stages=stages)
