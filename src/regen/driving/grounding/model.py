"""Model grounding of a driving cause path: the model writes the roles, narrative and FSM.

Two calls per path, each with a small flat schema built for that path
(:mod:`regen.driving.grounding.answers`): (1) the narrative and, per actor, the motion primitive,
start location and speed class the causal graph left open (what it chose is binding and not
asked); (2) the FSM as abstract states over the fixed predicate library, each with its stage
number. Everything is validated; the LLM layer re-asks on a validation error. What is still
unusable after that falls back to the rule-based part:

* roles: the rule-based roles when the answer never validated, when no map can host the
  model's roles, or when their placement is infeasible but the rule-based one is not;
* narrative: the chain of events as a sentence;
* FSM: :func:`regen.driving.grounding.fsm_rules.rule_based_fsm` when the answer never validated (and,
  from then on, for every later path grounded with the same LLM client: it is not asked again)
  or the monitor's own check rejects it; a model FSM that lacks the cause states of an actor before
  the ego's reaction gets them from the rules (:func:`~regen.driving.grounding.fsm_rules.with_cause_states`,
  noted as "cause stages added by rules: ...").

What came from where is recorded in ``scenario.world`` (``grounder`` = ``model`` |
``model+rules`` | ``rule-based``; ``model_parts``, ``rule_parts``, ``grounding_notes``, the
provider id and the cache keys of the calls) and every fallback reason in
``scenario.fallbacks``. An over-strict model FSM (two things at the same instant) is left as the
model wrote it: verification relaxes it after simulation and records that in the verdict.

Error policy: rules replace a part only when the model's answer for it is malformed
(:class:`~regen.errors.MalformedAnswerError`: it never validated against the schema) or
validated but fails the checks after it (no map hosts its roles, their placement is infeasible
where the rules' is not, the monitor rejects its FSM). Every other error of the LLM layer (a
replay cache miss, an unreachable provider, a provider error, a missing key or model file)
propagates unchanged: a replay or configuration problem is never hidden behind the rules.
"""

from __future__ import annotations

import logging
import weakref
from typing import TYPE_CHECKING, Any

from regen.assets.database import AssetDatabase
from regen.core.graph import CausePath
from regen.core.scenario import FSM, Scenario
from regen.driving.assets import database as driving_database
from regen.driving.grounding.answers import (
    RoleOptions,
    chosen_roles,
    fsm_schema,
    role_options,
    role_schema,
)
from regen.driving.grounding.feasibility import available
from regen.driving.grounding.fsm_rules import (
    CAUSES_ADDED,
    RENAMED,
    actor_states,
    honest_names,
    with_cause_states,
)
from regen.driving.grounding.rules import (
    build_scenario,
    default_narrative,
    roles_of,
    rule_based_roles,
    template_of,
)
from regen.driving.primitives import get
from regen.driving.world.actors import RoleChoice
from regen.driving.world.egos import EgoTemplate
from regen.driving.world.locations import LOCATIONS, location_from_text
from regen.driving.world.replay import ego_template
from regen.driving.world.setting import DrivingParams, DrivingWorld
from regen.errors import ConfigError, GroundingError, MalformedAnswerError
from regen.templates import render
from regen.verify.monitor import validate_fsm

if TYPE_CHECKING:
    from regen.llm.client import LLM

log = logging.getLogger(__name__)

PKG = "regen.driving.grounding"
PURPOSE_ROLES = "ground_roles"
PURPOSE_FSM = "ground_fsm"
PARTS = ("narrative", "roles", "fsm")

# LLM clients whose model failed the FSM schema (after its re-asks) in this process -> the
# scenario where it did. The rules write their FSMs from then on: the small offline model that
# fails once fails the same way again (it keeps the same impossible speed), and each failure
# costs a call and its re-asks (about 100 s on a CPU).
_FSM_FAILED: weakref.WeakKeyDictionary[LLM, str] = weakref.WeakKeyDictionary()


def path_roles(path: CausePath, db: AssetDatabase) -> list[RoleChoice]:
    """The path's roles as the graph fixed them, with defaults for what it left open (the model
    chooses those). :class:`UngroundableError` for a choice of the graph that no grounding can
    honor, GroundingError for unknown assets and contradictory values: no answer can fix them,
    so the model is not asked."""
    return rule_based_roles(path, db)


def _hints(pe_props: dict[str, list[str]]) -> str:
    """What the graph chose for one entity (start locations as the ids grounding uses)."""
    out = []
    for key, values in pe_props.items():
        if key == "start_location":
            values = [location_from_text(v) or v for v in values]
        if values:
            out.append(f"{key}={' / '.join(values)}")
    return ", ".join(out)


def _choices(o: RoleOptions, fields: set[str]) -> list[str]:
    """The prompt's lines of what the model chooses for one actor (only the schema's fields)."""
    if f"{o.name}_behavior" in fields:
        return [f'{o.name}_behavior "{prim}" starts at: {", ".join(locs)}' for prim, locs in o.locations.items()]
    if f"{o.name}_start" in fields:
        return [f'{o.name}_start (for "{prim}"): {", ".join(locs)}' for prim, locs in o.locations.items()]
    return []


def roles_prompt(path: CausePath, options: list[RoleOptions], schema: type) -> str:
    db_assets = driving_database().assets
    fields = set(schema.model_fields)
    actors = []
    for o, pe in zip(options, path.entities, strict=True):
        actors.append({"name": o.name, "description": db_assets[o.asset].description,
                       "hints": _hints(pe.properties), "choices": _choices(o, fields)})
    used = dict.fromkeys(loc for o in options if {f"{o.name}_behavior", f"{o.name}_start"} & fields
                         for loc in o.all_locations)
    keys = list(schema.model_fields)
    keys = keys[1:] + keys[:1]  # the narrative last in the sentence, first in the JSON
    return render(PKG, "ground_roles", behavior=path.behavior.text, events=path.events,
                  actors=actors, places=[(loc, LOCATIONS[loc].description) for loc in used], keys=keys)


def _actor_line(r: RoleChoice) -> str:
    bits = [r.asset]
    if r.primitive and r.location:
        bits.append(f"{r.primitive.replace('_', ' ')} from {r.location}")
        if get(r.primitive).moves:  # (a light or sensor has the role 'stationary')
            bits.append(f"{r.speed_class} speed")
    bits += [f"{k}={v}" for k, v in r.properties.items()]
    return f"{r.name}: " + ", ".join(bits)


def _cause_hint(r: RoleChoice, template: EgoTemplate) -> str:
    """How the actor's part in the cause shows, in predicate calls: the last of the rules' cause
    states (a light's red, not its green before; the rules add the earlier ones if missing)."""
    cause = actor_states(r, template).cause
    return " and ".join(map(str, cause[-1][1])) if cause else ""


def fsm_prompt(narrative: str, roles: list[RoleChoice], template: EgoTemplate) -> str:
    preds = [f"{s.signature()}: {s.doc}" for s in available(roles, template)]
    return render(PKG, "ground_fsm", narrative=narrative, ego=template.description,
                  actors=[(_actor_line(r), _cause_hint(r, template)) for r in roles], predicates=preds)


class _Grounding:
    """Bookkeeping of one model grounding: which part came from where, and why."""

    def __init__(self, llm: LLM):
        self.llm = llm
        self.source: dict[str, str] = {}
        self.fallbacks: list[str] = []  # what the rules wrote because the model's answer was unusable
        self.calls: list[str] = []

    def ask(self, prompt: str, schema: type, purpose: str) -> Any | None:
        """The validated answer, or None (and a fallback note) when it never validated.

        Only a malformed answer is caught: every other error of the LLM layer propagates.
        """
        try:
            answered = self.llm.ask(prompt, schema, purpose=purpose,
                                    system=render(PKG, "ground_system"))
        except MalformedAnswerError as exc:
            self.fallbacks.append(f"{purpose}: the model's answer was unusable ({exc}); used the rules")
            return None
        self.calls.append(answered.call_id)
        return answered.value

    def use(self, part: str, source: str, fallback: str | None = None) -> None:
        """Record where ``part`` came from, and why the rules wrote it when they did."""
        self.source[part] = source
        if fallback:
            self.fallbacks.append(fallback)

    @property
    def grounder(self) -> str:
        used = {self.source.get(p, "rules") for p in PARTS}
        if used == {"model"}:
            return "model"
        return "model+rules" if "model" in used else "rule-based"

    def finish(self, scenario: Scenario) -> Scenario:
        notes = {"grounding_notes": "; ".join(self.fallbacks)} if self.fallbacks else {}
        world = DrivingWorld.of(scenario).updated(
            grounder=self.grounder,
            model_parts=",".join(p for p in PARTS if self.source.get(p) == "model"),
            rule_parts=",".join(p for p in PARTS if self.source.get(p) != "model"),
            llm=self.llm.provider.id,
            model_calls=",".join(self.calls),
            **notes,
        ).as_world()
        return scenario.model_copy(update={"world": world,
                                           "fallbacks": list(scenario.fallbacks) + self.fallbacks})


def _build(path: CausePath, roles: list[RoleChoice], narrative: str, seed: int,
           db: AssetDatabase) -> Scenario:
    return build_scenario(path, roles, narrative=narrative, fsm=None, grounder="model", seed=seed, db=db)


def _ground_roles(path: CausePath, g: _Grounding, template: EgoTemplate, defaults: list[RoleChoice],
                  seed: int, db: AssetDatabase) -> Scenario:
    """Call 1 and the scenario it gives (rule-based roles where the model's are unusable)."""
    options = [role_options(r, db, template) for r in defaults]
    schema = role_schema(options, defaults, template)
    answer = g.ask(roles_prompt(path, options, schema), schema, PURPOSE_ROLES)
    narrative = default_narrative(path)
    if answer is None:
        g.use("narrative", "rules")
        g.use("roles", "rules")
        return _build(path, defaults, narrative, seed, db)
    g.use("narrative", "model")
    narrative = " ".join(answer.narrative.split())
    roles = chosen_roles(answer, options, defaults)
    try:
        scenario = _build(path, roles, narrative, seed, db)
    except GroundingError as exc:
        g.use("roles", "rules", f"{PURPOSE_ROLES}: the model's roles cannot be grounded ({exc}); "
              "used the rule-based roles")
        return _build(path, defaults, narrative, seed, db)
    if scenario.solver.status == "infeasible" and roles != defaults:
        try:
            fallback = _build(path, defaults, narrative, seed, db)
        except GroundingError:
            fallback = None
        if fallback is not None and fallback.solver.status != "infeasible":
            g.use("roles", "rules", f"{PURPOSE_ROLES}: the model's roles have no placement "
                  f"({'; '.join(scenario.solver.conflicts)}); used the rule-based roles")
            return fallback
    g.use("roles", "model")
    return scenario


def _ground_fsm(g: _Grounding, scenario: Scenario, roles: list[RoleChoice]) -> FSM | None:
    """Call 2: the model's FSM, or None (rule-based FSM kept) with the reason noted."""
    if scenario.solver.status == "infeasible":
        g.use("fsm", "rules", f"{PURPOSE_FSM}: not asked, the placement is infeasible")
        return None
    failed = _FSM_FAILED.get(g.llm)
    if failed is not None:
        g.use("fsm", "rules", f"{PURPOSE_FSM}: not asked, the model failed its schema earlier with this "
              f"client (scenario {failed}); used the rules")
        return None
    template = template_of(scenario)
    schema = fsm_schema(roles, template)
    answer = g.ask(fsm_prompt(scenario.narrative, roles, template), schema, PURPOSE_FSM)
    if answer is None:
        _FSM_FAILED[g.llm] = scenario.id
        g.use("fsm", "rules")
        return None
    try:
        fsm = answer.to_fsm()
    except ValueError as exc:  # pydantic's own FSM checks; the schema should prevent this
        g.use("fsm", "rules", f"{PURPOSE_FSM}: the model's FSM is inconsistent ({exc}); used the rules")
        return None
    problems = validate_fsm(fsm, {e.name for e in scenario.entities}, "driving")
    if problems:
        g.use("fsm", "rules", f"{PURPOSE_FSM}: the model's FSM fails the monitor's check "
              f"({'; '.join(problems)}); used the rules")
        return None
    g.use("fsm", "model")
    fsm, renamed = honest_names(fsm)
    if renamed:
        g.fallbacks.append(f"{RENAMED}{'; '.join(renamed)}")
    return fsm


def ground_with_model(path: CausePath, llm: LLM, *, seed: int = 0,
                      db: AssetDatabase | None = None) -> Scenario:
    """Ground one cause path with the model's roles, narrative and FSM (two calls).

    The model fills only what the path's graph left open; what the graph chose is binding.
    Unusable answers fall back to the rule-based parts (recorded in ``world`` and
    ``scenario.fallbacks``); cause stages the model's FSM lacks are added by the rules (recorded
    there too, ``fsm_source`` = ``model+rules``). Raises :class:`UngroundableError` before any
    call when a choice of the graph cannot be honored, :class:`GroundingError` when the path
    itself cannot be grounded (unknown asset, contradictory properties); errors of the LLM layer
    other than a malformed answer (replay miss, unreachable provider, provider error, missing key
    or model file) propagate unchanged, so a replay or configuration problem is never silently
    hidden.
    """
    db = db or driving_database()
    try:
        template = ego_template(path.behavior.text, DrivingParams.of(path.behavior))
    except ConfigError as exc:
        raise GroundingError(str(exc)) from None
    defaults = path_roles(path, db)
    g = _Grounding(llm)
    scenario = _ground_roles(path, g, template, defaults, seed, db)
    roles = roles_of(scenario)
    fsm = _ground_fsm(g, scenario, roles)
    if fsm is not None:
        fsm, added = with_cause_states(fsm, roles, template_of(scenario))
        if added:
            g.fallbacks.append(f"{CAUSES_ADDED}{'; '.join(added)}")
        scenario = Scenario.model_validate({**scenario.model_dump(), "fsm": fsm.model_dump(),
                                            "fsm_source": "model+rules" if added else "model"})
    return g.finish(scenario)


__all__ = ["fsm_prompt", "ground_with_model", "path_roles", "roles_prompt"]
