"""Answer schemas for model grounding, built per cause path: what the model fills in.

Two small, flat schemas (the offline model is a 1.5B model with schema-constrained decoding):

* roles: a narrative plus, per actor, ``<actor>_behavior``, ``<actor>_start`` and
  ``<actor>_speed``, each a ``Literal`` of what the asset supports, the primitive library
  implements and the ego's map can host; only those the causal graph left open (what it
  chose is binding and is not asked);
* FSM: per actor (every actor a required key, the ego last), its abstract states
  ``{"stage", "name", "holds"}``. Each state carries the number of the stage it belongs to, so
  a stage can never name a state that does not exist, and no actor can be left without one;
  ``holds`` are 1-3 predicate calls that name the state's actor, written as
  ``name(a, b, param=value)`` with an optional leading ``not``. The JSON schema carries a regex
  over the exact predicate and actor names, so constrained decoding can only write known calls
  that can hold; the validators here parse them (nothing is
  ever evaluated) and check arity, parameters, and whether the call can hold at all for the
  chosen primitive and properties (the rules of :mod:`regen.driving.grounding.feasibility`).

Validators raise ``ValueError`` with a message that says what is allowed: the LLM layer sends
it back to the model as a re-ask.
"""

from __future__ import annotations

import itertools
import math
import re
from dataclasses import dataclass
from typing import Annotated, Any, Literal

from pydantic import AfterValidator, Field, create_model, field_validator, model_validator

from regen.assets.database import AssetDatabase
from regen.core.base import Answer
from regen.core.scenario import FSM, AbstractState, PredicateCall, Stage, StateRef
from regen.driving.assets import database
from regen.driving.grounding.feasibility import (
    available,
    contradiction,
    light_values,
    never_holds,
    top_speed,
)
from regen.driving.grounding.rules import choose_map, implied
from regen.driving.primitives import get, is_state_only
from regen.driving.primitives.base import SPEED_CLASSES
from regen.driving.world.actors import RoleChoice
from regen.driving.world.egos import EgoTemplate
from regen.errors import GroundingError
from regen.verify.predicates import PredicateSpec

MAX_STAGES = 6
MAX_ACTOR_STATES = 3  # a short list: the small model pads long ones with repeats
NARRATIVE_CHARS = 400  # [characters]
LIGHT_VALUES = ("red", "yellow", "green", "off")
_STATE_NAME = re.compile(r"^[a-z][a-z0-9_]{0,31}$")
_CALL = re.compile(r"^(not )?([a-z_]+)\(([a-z0-9_]+)(?:, ?([a-z0-9_]+))?"
                   r"(?:, ?([a-z_]+)=([a-z0-9.]+))?\)$")


# --- roles ------------------------------------------------------------------------------------


@dataclass(frozen=True, kw_only=True)
class RoleOptions:
    """What the model may choose for one actor (a single option: nothing to choose)."""

    name: str
    asset: str
    primitives: tuple[str, ...]
    locations: dict[str, tuple[str, ...]]  # primitive -> start locations the map can host
    moves: bool  # whether the model chooses a speed class (it moves; the graph left it open)

    @property
    def all_locations(self) -> tuple[str, ...]:
        seen: dict[str, None] = {}
        for locs in self.locations.values():
            seen.update(dict.fromkeys(locs))
        return tuple(seen)


def role_options(role: RoleChoice, db: AssetDatabase, template: EgoTemplate) -> RoleOptions:
    """The primitives and start locations ``role``'s asset supports on the ego's possible maps,
    within what the graph fixed (``role.fixed``): a fixed behavior or start is the only option."""
    if is_state_only(role.asset):
        return RoleOptions(name=role.name, asset=role.asset, primitives=(), locations={}, moves=False)
    prims = (role.primitive,) if "behavior" in role.fixed else db.assets[role.asset].behaviors
    locations: dict[str, tuple[str, ...]] = {}
    for prim in prims:
        if "target_speed" in role.fixed and not get(prim).moves:
            continue  # the graph gave it a speed: it moves
        ok = []
        for loc in get(prim).starts:
            if "start_location" in role.fixed and loc != role.location:
                continue
            trial = RoleChoice(name=role.name, asset=role.asset, primitive=prim, location=loc,
                               speed_class=role.speed_class)
            try:
                choose_map(template, [trial])
            except GroundingError:
                continue
            ok.append(loc)
        if ok:
            locations[prim] = tuple(ok)
    moves = "target_speed" not in role.fixed and any(get(p).moves for p in locations)
    return RoleOptions(name=role.name, asset=role.asset, primitives=tuple(locations), locations=locations,
                       moves=moves)


def _lit(values: tuple[str, ...]) -> Any:
    return Literal[values]  # type: ignore[valid-type]


def _narrative(text: str) -> str:
    text = " ".join(text.split())
    if len(text) < 10:
        raise ValueError("the narrative is empty or too short: tell in one or two sentences "
                         "what happens and why the ego-vehicle reacts")
    if len(text) > NARRATIVE_CHARS:  # cut at a word rather than spend a re-ask on length
        text = text[:NARRATIVE_CHARS].rsplit(" ", 1)[0] + " ..."
    return text


def role_schema(options: list[RoleOptions], defaults: list[RoleChoice],
                template: EgoTemplate) -> type[Answer]:
    """The per-path roles schema: ``narrative`` and, per actor, the behavior, start and speed
    the graph left open (and that have more than one option).

    ``defaults`` (the rule-based roles, same order as ``options``: the graph's choices, else
    defaults) fill what the model does not choose.
    """
    # No length bounds in the JSON schema: llama.cpp turns maxLength into a deeply nested
    # grammar rule that made constrained decoding ~4x slower; the validator bounds it instead.
    fields: dict[str, Any] = {"narrative": (Annotated[str, AfterValidator(_narrative)], ...)}
    for o in options:
        if len(o.primitives) > 1:
            fields[f"{o.name}_behavior"] = (_lit(o.primitives), ...)
        if len(o.all_locations) > 1:
            fields[f"{o.name}_start"] = (_lit(o.all_locations), ...)
        if o.moves:
            fields[f"{o.name}_speed"] = (_lit(SPEED_CLASSES), ...)

    def _check(self: Any) -> Any:
        problems = []
        for o, d in zip(options, defaults, strict=True):
            prim, loc, _ = pick(self, o, d)
            allowed = o.locations.get(prim, ())
            if allowed and loc not in allowed:
                problems.append(f"{o.name}_start {loc!r} does not suit {o.name}_behavior "
                                f"{prim!r}; {prim} starts at: {', '.join(allowed)}")
        if problems:
            raise ValueError("; ".join(problems))
        try:
            choose_map(template, chosen_roles(self, options, defaults))
        except GroundingError as exc:
            raise ValueError(f"{exc}; choose other start locations") from None
        return self

    return create_model("GroundRoles", __base__=Answer,
                        __validators__={"_check": model_validator(mode="after")(_check)},
                        **fields)


def pick(answer: Any, o: RoleOptions, default: RoleChoice) -> tuple[str, str, str]:
    """(primitive, start location, speed class) of one actor in a roles answer (the default's
    where the answer has no field: the graph fixed it, or there is one option)."""
    if not o.primitives:
        return default.primitive, default.location, default.speed_class
    prim = getattr(answer, f"{o.name}_behavior", None) or o.primitives[0]
    loc = getattr(answer, f"{o.name}_start", None)
    if loc is None:
        locs = o.locations.get(prim, ())
        loc = default.location if default.location in locs or not locs else locs[0]
    speed = getattr(answer, f"{o.name}_speed", None) or default.speed_class
    return prim, loc, speed


def chosen_roles(answer: Any, options: list[RoleOptions], defaults: list[RoleChoice]) -> list[RoleChoice]:
    """The roles a (validated) roles answer describes; properties stay those of the path."""
    out = []
    for o, d in zip(options, defaults, strict=True):
        prim, loc, speed = pick(answer, o, d)
        out.append(RoleChoice(name=d.name, asset=d.asset, primitive=prim, location=loc, speed_class=speed,
                              properties=implied(prim, d.asset, dict(d.properties), database()), fixed=d.fixed))
    return out


# --- FSM --------------------------------------------------------------------------------------


NUMBER = "([0-9]|[1-9][0-9]|1[0-9][0-9])([.][0-9]+)?"  # 0 to 199.9..: the range parse_call accepts


def below(limit: float) -> str:
    """A regex of numbers below ``limit`` (>= 1): integer parts 0 .. floor(limit) - 1, so no
    value at or above the limit can be written (conservative for a fractional limit)."""
    n = min(200, max(1, math.floor(limit)))  # integer parts allowed: 0 .. n-1
    if n <= 10:
        return f"[0-{n - 1}]([.][0-9]+)?"
    tens, units = divmod(n, 10)
    alts = ["[0-9]"]
    if tens > 1:
        alts.append(f"[1-{tens - 1}][0-9]" if tens <= 10 else "[1-9][0-9]")
    if tens >= 10:
        hundreds_tens = tens - 10
        if hundreds_tens > 0:
            alts.append(f"1[0-{hundreds_tens - 1}][0-9]")
        if units:
            alts.append(f"1{hundreds_tens}[0-{units - 1}]")
    elif units:
        alts.append(f"{tens}[0-{units - 1}]")
    return "(" + "|".join(alts) + ")([.][0-9]+)?"


def call_pattern(specs: list[PredicateSpec], actors: list[str],
                 roles: dict[str, RoleChoice] | None = None, template: EgoTemplate | None = None,
                 about: str | None = None) -> str:
    """The regex of a predicate call over exact predicate, actor and parameter names (for the
    schema): constrained decoding can then write no unknown name at all. With the scenario's
    ``roles`` and ``template``, only calls that can hold: actor combinations that
    :func:`~regen.driving.grounding.feasibility.never_holds` rules out, an actor compared with itself, a
    light value the light never shows and speed thresholds at or above what the actor can reach
    cannot be written either, so no answer is thrown away for them. With ``about``, only calls
    that name that actor (the calls of one actor's state)."""
    num = NUMBER  # no backslash escapes: they do not survive the grammar
    alts = []
    for s in specs:
        per: list[tuple[str, str | None]] = []  # (args regex, first actor if fixed)
        if roles is None or template is None:
            who = "(" + "|".join(re.escape(a) for a in actors) + ")"
            per.append((", ".join([who] * s.arity), None))
        else:
            for c in itertools.product(actors, repeat=s.arity):
                call = PredicateCall(name=s.name, args=list(c))
                if (len(set(c)) < s.arity or (about is not None and about not in c)
                        or (s.name != "light_is" and never_holds(call, roles, template))):
                    continue
                per.append((", ".join(re.escape(a) for a in c), c[0]))
        for args, first in per:
            if s.name == "light_is":  # the value is what the state is about: always written
                shown = _shown(first, roles, template)
                if shown:  # (a light that shows none of them has no such call)
                    alts.append(rf"{s.name}\({args}, (value=({'|'.join(shown)}))\)")
                continue
            params = []
            for k, default in s.params.items():
                if not isinstance(default, str):
                    top = _top(first, roles, template) if k == "min_speed" else None
                    params.append(f"{k}={below(top) if top is not None else num}")
            extra = f"(, ({'|'.join(params)}))?" if params else ""
            alts.append(rf"{s.name}\({args}{extra}\)")
    return "^(not )?(" + "|".join(alts) + ")$"


def _shown(actor: str | None, roles: dict[str, RoleChoice] | None,
           template: EgoTemplate | None) -> list[str]:
    """The light values ``light_is`` may name for ``actor``: those it shows (all when unknown)."""
    if actor is None or roles is None or template is None:
        return list(LIGHT_VALUES)
    r = roles.get(actor)
    if r is None or r.asset != "traffic_light":
        return []
    shown = light_values(r, template)
    return [v for v in LIGHT_VALUES if v in shown]


def _top(actor: str | None, roles: dict[str, RoleChoice] | None, template: EgoTemplate | None) -> float | None:
    """The highest speed [m/s] ``actor`` reaches in the scenario (None: unknown or no motion)."""
    if actor is None or roles is None or template is None:
        return None
    if actor == "ego":
        return max([template.speed0] + [v for _, v, _ in template.schedule])
    r = roles.get(actor)
    return top_speed(r) if r is not None else None


def parse_call(text: str, specs: dict[str, PredicateSpec], actors: list[str]) -> PredicateCall:
    """One written call, e.g. ``not in_front(sedan1, ego, distance=20)``, as a PredicateCall."""
    m = _CALL.match(" ".join(text.split()))
    if m is None:
        raise ValueError(f"{text!r} is not a predicate call; write name(actor) or "
                         "name(actor, actor), optionally with one param=value and a leading 'not '")
    neg, name, a, b, key, val = m.groups()
    spec = specs.get(name)
    if spec is None:
        raise ValueError(f"{text!r}: {name!r} is not a predicate of this scenario; choose from "
                         f"{', '.join(specs)}")
    args = [x for x in (a, b) if x is not None]
    if len(args) != spec.arity:
        raise ValueError(f"{text!r}: {name} takes {spec.arity} actor(s): {spec.signature()}")
    bad = [x for x in args if x not in actors]
    if bad:
        raise ValueError(f"{text!r}: unknown actor {bad[0]!r}; the actors are {', '.join(actors)}")
    if len(args) == 2 and args[0] == args[1]:
        raise ValueError(f"{text!r} compares {args[0]} with itself; name two different actors")
    params: dict[str, float | str] = {}
    if key is not None:
        if key not in spec.params:
            allowed = ", ".join(spec.params) or "none"
            raise ValueError(f"{text!r}: {name} has no parameter {key!r} (it takes: {allowed})")
        params[key] = _param_value(text, name, key, val, spec.params[key])
    return PredicateCall(name=name, args=args, params=params, negate=neg is not None)


def _param_value(text: str, name: str, key: str, val: str, default: float | str) -> float | str:
    if isinstance(default, str):
        if name == "light_is" and val not in LIGHT_VALUES:
            raise ValueError(f"{text!r}: value must be one of {', '.join(LIGHT_VALUES)}")
        return val
    try:
        num = float(val)
    except ValueError:
        raise ValueError(f"{text!r}: {key} must be a number") from None
    if not 0.0 <= num <= 200.0:
        raise ValueError(f"{text!r}: {key} must lie between 0 and 200")
    return num


def fsm_schema(roles: list[RoleChoice], template: EgoTemplate) -> type[Answer]:
    """The per-path FSM schema: per actor (each one required, the ego last), its states with
    their stage number and predicate calls that name that actor. An actor without a state
    cannot be written, nor a call about another actor."""
    actors = ["ego"] + [r.name for r in roles]
    by_name = {r.name: r for r in roles}
    specs = {s.name: s for s in available(roles, template)}
    stage_type = _lit(tuple(range(1, MAX_STAGES + 1)))

    def state_model(actor: str) -> type[Answer]:
        pattern = call_pattern(list(specs.values()), actors, by_name, template, about=actor)
        call_text = Annotated[str, Field(json_schema_extra={"pattern": pattern})]

        def _name(cls: type, v: str) -> str:
            if not _STATE_NAME.match(v):
                raise ValueError(f"state name {v!r}: use lower-case letters, digits and '_' "
                                 "(at most 32), starting with a letter")
            return v

        def _calls(self: Any) -> Any:
            problems, calls = [], []
            for text in self.holds:
                call = parse_call(text, specs, actors)
                calls.append(call)
                if actor not in call.args:
                    problems.append(f"{text!r} does not name {actor}")
                why = never_holds(call, by_name, template)
                if why:
                    problems.append(why)
            clash = contradiction(calls)
            if clash:
                problems.append(clash)
            if problems:
                raise ValueError(f"state {self.name!r} of {actor}: " + "; ".join(problems)
                                 + "; choose predicates that can hold")
            return self

        return create_model(
            f"State_{actor}", __base__=Answer,
            __validators__={"check_name": field_validator("name")(classmethod(_name)),
                            "check_calls": model_validator(mode="after")(_calls)},
            stage=(stage_type, ...),
            # unbounded in the schema (a bounded repeat is a slow nested grammar rule)
            name=(Annotated[str, Field(json_schema_extra={"pattern": "^[a-z][a-z0-9_]*$"})], ...),
            holds=(list[call_text], Field(min_length=1, max_length=3)))  # type: ignore[valid-type]

    order = [a for a in actors if a != "ego"] + ["ego"]  # the causes first, then the ego's reaction
    fields: dict[str, Any] = {
        a: (list[state_model(a)], Field(min_length=1, max_length=MAX_ACTOR_STATES))  # type: ignore[misc]
        for a in order}
    actor_states = create_model("ActorStates", __base__=Answer, **fields)

    class GroundFSM(Answer):
        states: actor_states  # type: ignore[valid-type]

        @model_validator(mode="after")
        def _whole(self) -> GroundFSM:
            if len({s.stage for s in flat_states(self)}) < 2:
                raise ValueError("all states share one stage; use stage numbers to order them "
                                 "(1 at the start, higher later)")
            return self

        def to_fsm(self) -> FSM:
            return answer_fsm(self, specs, actors)

    return GroundFSM


@dataclass(frozen=True)
class FlatState:
    """One state of an FSM answer, its actor named."""

    stage: int
    actor: str
    name: str
    holds: tuple[str, ...]


def flat_states(answer: Any) -> list[FlatState]:
    """The states of a per-actor FSM answer, each with its actor. A name one actor uses for two
    different meanings gets a number (``braking_2``): names are labels, the calls the meaning."""
    out: list[FlatState] = []
    for actor, states in answer.states:
        seen: dict[str, tuple[str, ...]] = {}
        for s in states:
            holds = tuple(" ".join(h.split()) for h in s.holds)
            name, k = s.name, 1
            while seen.setdefault(name, holds) != holds:
                k += 1
                name = f"{s.name}_{k}"
            out.append(FlatState(stage=s.stage, actor=actor, name=name, holds=holds))
    return out



def answer_fsm(answer: Any, specs: dict[str, PredicateSpec], actors: list[str]) -> FSM:
    """The FSM of a validated answer: stages in order of their numbers (gaps closed)."""
    flat = flat_states(answer)
    states: dict[tuple[str, str], AbstractState] = {}
    for s in flat:
        states.setdefault((s.actor, s.name), AbstractState(
            name=s.name, actor=s.actor, all_of=[parse_call(c, specs, actors) for c in s.holds]))
    stages: list[Stage] = []
    for k in sorted({s.stage for s in flat}):
        refs = list(dict.fromkeys((s.actor, s.name) for s in flat if s.stage == k))
        stage = Stage(conditions=[StateRef(actor=a, state=n) for a, n in refs])
        if not stages or stage != stages[-1]:  # a repeated stage adds nothing
            stages.append(stage)
    return FSM(states=list(states.values()), stages=stages)
