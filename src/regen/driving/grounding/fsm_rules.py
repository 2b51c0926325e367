"""The rule-based FSM, and the cause stages every driving FSM must have.

The rule-based FSM is a deterministic default per ego template and per actor primitive, used for
hand-written chains and whenever the model's FSM is unusable. Stages: (1) every actor's initial
state with the ego's initial state, (2) each actor's cause states, one stage each, actors in
path order, (3) the ego's reaction states, one stage each, (4) the actors' final states together.

Cause fidelity: the cause states of an actor (its primitive's, see
:class:`~regen.driving.primitives.base.RuleStates`) show the cause playing out and are marked
``cause=True``. :func:`with_cause_states` adds them to an FSM the model wrote when it lacks them
before the ego's reaction, so no FSM can be accepted without its cause having played out.
"""

from __future__ import annotations

import re
from collections.abc import Sequence

from regen.core.scenario import FSM, AbstractState, PredicateCall, Stage, StateRef
from regen.driving.primitives import for_actor
from regen.driving.primitives.base import RuleStates, State, pred
from regen.driving.primitives.shared.attention import min_wait, waiting_at_green
from regen.driving.world.actors import RoleChoice
from regen.driving.world.egos import EgoTemplate
from regen.verify.predicates import get_predicate

Calls = list[PredicateCall]
CAUSES_ADDED = "cause stages added by rules: "  # how the note of cause stages added to an FSM starts
RENAMED = "state names replaced by rules: "  # how the note of model-written state names replaced starts


def ego_states(t: EgoTemplate) -> tuple[State, list[State]]:
    """(initial state, reaction states in order) of the ego."""
    return t.ego_states()


def actor_states(r: RoleChoice, t: EgoTemplate, roles: Sequence[RoleChoice] = ()) -> RuleStates:
    """The initial, cause and final states of one actor: those of its primitive, each with the
    states its properties show all along (siren, hazard lights); a distracted driver waiting at
    a light of ``roles`` shows it stopped on green first."""
    states = for_actor(r.asset, r.primitive).rule_states(r, t)
    light = waiting_at_green(roles, t).get(r.name)
    wait = min_wait(r)
    if light is not None and wait is not None:
        states = RuleStates(initial=states.initial, final=states.final, cause=(
            ("stopped_on_green", [pred("stopped_on_green", r.name, light, min_duration=wait),
                                  pred("in_front", r.name, "ego", distance=20.0)]),) + tuple(states.cause[1:]))
    extra: Calls = []
    if r.properties.get("siren") == "on":
        extra.append(pred("siren_on", r.name))
    if r.properties.get("hazard_lights") == "on":
        extra.append(pred("hazard_lights_on", r.name))

    def add(st: State) -> State:
        return (st[0], st[1] + extra)

    return RuleStates(initial=states.initial and add(states.initial), cause=tuple(map(add, states.cause)),
                      final=states.final and add(states.final))


def cause_states(roles: list[RoleChoice], t: EgoTemplate) -> list[AbstractState]:
    """Every actor's cause states (marked ``cause``), actors in path order, each in its order."""
    lights = set(waiting_at_green(roles, t).values())  # a light a driver waits at shows its green first
    ordered = [r for r in roles if r.name in lights] + [r for r in roles if r.name not in lights]
    return [AbstractState(name=name, actor=r.name, all_of=calls, cause=True)
            for r in ordered for name, calls in actor_states(r, t, roles).cause]


def rule_based_fsm(roles: list[RoleChoice], t: EgoTemplate) -> FSM:
    """The default FSM for a set of actors around an ego template."""
    states: list[AbstractState] = []
    first: list[StateRef] = []
    finals: list[StateRef] = []
    for r in roles:
        own = actor_states(r, t, roles)
        for st, bucket in ((own.initial, first), (own.final, finals)):
            if st is not None:
                states.append(AbstractState(name=st[0], actor=r.name, all_of=st[1]))
                bucket.append(StateRef(actor=r.name, state=st[0]))
    causes = cause_states(roles, t)
    states += causes
    (ename, ecalls), events = ego_states(t)
    states.append(AbstractState(name=ename, actor="ego", all_of=ecalls))
    stages = [Stage(conditions=first + [StateRef(actor="ego", state=ename)])]
    for name, calls in t.prelude():  # a turn that comes before the causes of the stop
        states.append(AbstractState(name=name, actor="ego", all_of=calls))
        stages.append(Stage(conditions=[StateRef(actor="ego", state=name)]))
    stages += [Stage(conditions=[StateRef(actor=c.actor, state=c.name)]) for c in causes]
    for name, calls in events:
        states.append(AbstractState(name=name, actor="ego", all_of=calls))
        stages.append(Stage(conditions=[StateRef(actor="ego", state=name)]))
    if finals:
        stages.append(Stage(conditions=finals))
    return FSM(states=states, stages=stages)


# --- cause stages in an FSM the model wrote ----------------------------------------------------


def is_reaction(state: AbstractState, t: EgoTemplate) -> bool:
    """Whether ``state`` is one of the ego's reaction (braking, stopped, changing lane, driving
    off ...) for the ego template ``t``."""
    return t.is_reaction(state)


def _param(call: PredicateCall, key: str) -> float | int | str | bool:
    spec = get_predicate(call.name, "driving")
    return call.params.get(key, spec.params.get(key, 0.0))


def _at_least_as_strict(have: PredicateCall, want: PredicateCall) -> bool:
    """Whether ``have`` holds only where ``want`` holds (same predicate, actors and sign, and
    a threshold no looser)."""
    if (have.name, have.args, have.negate) != (want.name, want.args, want.negate):
        return False
    for key in set(want.params) | set(have.params):
        h, w = _param(have, key), _param(want, key)
        if isinstance(w, str) or isinstance(h, str) or key == "lane":
            if str(h) != str(w):
                return False
            continue
        # an upper bound (max_speed, a distance within) is stricter when lower, a lower bound
        # (min_speed, min_gap, far_from's distance) when higher; negation flips both
        lower = key in ("max_speed", "tolerance") or (key == "distance" and have.name != "far_from")
        if lower != have.negate:
            if float(h) > float(w):
                return False
        elif float(h) < float(w):
            return False
    return True


def entails(have: AbstractState, want: AbstractState) -> bool:
    """Whether the state ``have`` (of the same actor) holds only where ``want`` holds: each call
    of ``want`` has a call in ``have`` at least as strict."""
    return have.actor == want.actor and all(any(_at_least_as_strict(h, w) for h in have.all_of)
                                            for w in want.all_of)


def _free_name(taken: set[tuple[str, str]], actor: str, name: str) -> str:
    if (actor, name) not in taken:
        return name
    k = 2
    while (actor, f"{name}_{k}") in taken:
        k += 1
    return f"{name}_{k}"


def with_cause_states(fsm: FSM, roles: list[RoleChoice], t: EgoTemplate) -> tuple[FSM, list[str]]:
    """``fsm`` with every actor's cause states, in their order, before the ego's first reaction.

    Per actor, its cause states are looked for in order in the stages before the first reaction
    stage: a state of the FSM that entails one (in a later stage than the previous one found) is
    marked ``cause``. A cause state without such a state is added in a stage of its own: the
    actor's last one right before the first reaction stage (at the end when the FSM has none),
    an earlier one right after the stage where the one before it was found (else first).
    Returns the FSM and, per added state, ``'<actor>: <state> (<predicates>)'``.
    """
    stages = list(fsm.stages)
    first = next((k for k, st in enumerate(stages)
                  if any(is_reaction(fsm.state(c.actor, c.state), t) for c in st.conditions)), len(stages))
    states = {(s.actor, s.name): s for s in fsm.states}
    added: list[str] = []
    before: dict[int, list[Stage]] = {}  # stage index -> stages added right before it
    every = cause_states(roles, t)  # with all roles: a driver's cause stage names the light it waits at
    for r in roles:
        wanted = [s for s in every if s.actor == r.name]
        found: list[int | None] = []
        after = -1
        for want in wanted:
            hit = next(((k, (c.actor, c.state)) for k in range(after + 1, first) for c in stages[k].conditions
                        if entails(states[(c.actor, c.state)], want)), None)
            if hit is None:
                found.append(None)
                continue
            after = hit[0]
            found.append(after)
            states[hit[1]] = states[hit[1]].model_copy(update={"cause": True})
        for i, want in enumerate(wanted):
            if found[i] is not None:
                continue
            # the last cause state lasts into the reaction: right before it; an earlier one (the
            # light still green, the door still closed) as early as its order allows
            at = first if i == len(wanted) - 1 else next((k + 1 for k in reversed(found[:i]) if k is not None), 0)
            name = _free_name(set(states), want.actor, want.name)
            states[(want.actor, name)] = want.model_copy(update={"name": name})
            before.setdefault(at, []).append(Stage(conditions=[StateRef(actor=want.actor, state=name)]))
            added.append(f"{want.actor}: {name} ({', '.join(str(c) for c in want.all_of)})")
    out: list[Stage] = []
    for k in range(len(stages) + 1):
        out += before.get(k, [])
        if k < len(stages):
            out.append(stages[k])
    return FSM(states=list(states.values()), stages=out), added


#: words of a state name that claim what only these predicates show (a model names a state
#: "colliding" while its calls say close_to and on_road): (pattern, predicates, what it claims)
_CLAIMS: tuple[tuple[re.Pattern[str], frozenset[str], str], ...] = tuple(
    (re.compile(pattern), needs, what) for pattern, needs, what in (
        (r"collid|collision|crash|\bhit|_hit|impact", frozenset({"collided", "collides", "collision"}),
         "a collision"),
        (r"brak", frozenset({"braking"}), "braking"),
        (r"accelerat|speeding_up", frozenset({"accelerating"}), "accelerating"),
        (r"chang\w*_lanes?|lane_chang|merg|swerv|cut\w*_in", frozenset({"changing_lane"}), "a lane change"),
    ))
#: light colours a state's name may claim -> the light_is value that shows it
_COLOURS = {"red": "red", "yellow": "yellow", "amber": "yellow", "green": "green"}
_DENIED = re.compile(r"(?:^|_)(?:no|not|non|avoid\w*|without|near|almost|pre|before|after|about_to|un)(?:_|$)")
_WORD = re.compile(r"[a-z0-9]+")


def _unclaimed(name: str, calls: Calls) -> str | None:
    """What a state's name claims that none of its (positive) calls shows, or None."""
    key = "_".join(_WORD.findall(name.lower()))
    if _DENIED.search(key):
        return None
    held = {c.name for c in calls if not c.negate}
    for pattern, needs, what in _CLAIMS:
        if pattern.search(key) and not held & needs:
            return what
    shown = {str(c.params.get("value")) for c in calls if c.name == "light_is" and not c.negate}
    for word, value in _COLOURS.items():  # 'red' holding light_is(..., green) claims a red light
        if re.search(rf"(?:^|_){word}(?:_|$)", key) and value not in shown:
            return f"a {word} light"
    return None


def honest_names(fsm: FSM) -> tuple[FSM, list[str]]:
    """``fsm`` with each state whose model-written name claims what its predicates do not show
    renamed after its predicates ('colliding' holding close_to(bicycle1, ego) and on_road(bicycle1)
    becomes 'close_to_ego_on_road'), and one note per rename. Names are labels (the calls are the
    meaning), but pictures and reports show them, and a verified scenario must not read
    'colliding' where nothing collided."""
    renamed: dict[tuple[str, str], str] = {}
    notes: list[str] = []
    taken = {(s.actor, s.name) for s in fsm.states}
    for s in fsm.states:
        what = _unclaimed(s.name, s.all_of)
        if what is None:
            continue
        base = "_".join(dict.fromkeys(
            "_".join([("not_" if c.negate else "") + c.name, *(a for a in c.args if a != s.actor),
                      *([str(c.params["value"])] if "value" in c.params else [])])
            for c in s.all_of))
        new, k = base, 1
        while (s.actor, new) in taken:
            k += 1
            new = f"{base}_{k}"
        taken.add((s.actor, new))
        renamed[(s.actor, s.name)] = new
        notes.append(f"{s.actor}: '{s.name}' renamed '{new}' (the name claims {what}; its predicates "
                     f"{', '.join(str(c) for c in s.all_of)} do not)")
    if not renamed:
        return fsm, []
    states = [s.model_copy(update={"name": renamed.get((s.actor, s.name), s.name)}) for s in fsm.states]
    stages = [st.model_copy(update={"conditions": [
        c.model_copy(update={"state": renamed.get((c.actor, c.state), c.state)}) for c in st.conditions]})
        for st in fsm.stages]
    return FSM(states=states, stages=stages), notes


__all__ = ["CAUSES_ADDED", "RENAMED", "actor_states", "cause_states", "ego_states", "entails", "honest_names",
           "is_reaction", "rule_based_fsm", "with_cause_states"]
