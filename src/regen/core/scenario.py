"""A grounded scenario: narrative, entities, the FSM that must play out, solved parameters.

The FSM is declarative. Abstract states are conjunctions of predicate calls from a fixed,
documented library (``regen.verify.predicates``); the model picks and orders them, and nothing
it writes is ever executed.
"""

from __future__ import annotations

from typing import Any, Literal, TypeVar

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

from regen.core.base import Model
from regen.core.behavior import Behavior
from regen.core.verdict import Fidelity

Scalar = float | int | str | bool


class PredicateCall(Model):
    """One predicate of the library applied to actors, e.g. ``behind(ambulance1, ego)``."""

    name: str
    args: list[str] = Field(default_factory=list)  # actor names
    params: dict[str, Scalar] = Field(default_factory=dict)  # e.g. {"distance": 10.0}
    negate: bool = False

    def __str__(self) -> str:
        extra = ", ".join(f"{k}={v}" for k, v in self.params.items())
        inner = ", ".join(self.args + ([extra] if extra else []))
        return f"{'not ' if self.negate else ''}{self.name}({inner})"


class AbstractState(Model):
    """A named abstract state of one actor: true at a step when all its predicates hold.

    ``cause`` marks the state in which the scenario's cause visibly plays out (a crossing actor
    on the ego's lane, a light turned red, the pet outside the door). Grounding puts every cause
    state in a stage before the robot's reaction, whoever wrote the FSM; a cause state that is
    never reached makes the verdict ``cause_not_shown``, not a plain FSM failure."""

    name: str
    actor: str
    all_of: list[PredicateCall] = Field(min_length=1)
    cause: bool = False


class StateRef(Model):
    actor: str
    state: str


class Stage(Model):
    """All conditions of a stage must hold at the same simulation step."""

    conditions: list[StateRef] = Field(min_length=1)


class FSM(Model):
    """Ordered stages; the last stage is the accepting one (paper: F)."""

    states: list[AbstractState] = Field(default_factory=list)
    stages: list[Stage] = Field(default_factory=list)

    @model_validator(mode="after")
    def _refs_known(self) -> FSM:
        known = {(s.actor, s.name) for s in self.states}
        for i, st in enumerate(self.stages):
            for c in st.conditions:
                if (c.actor, c.state) not in known:
                    raise ValueError(f"stage {i + 1} names the state {c.state!r} of {c.actor!r}, "
                                     "which no abstract state defines")
        return self

    def state(self, actor: str, name: str) -> AbstractState:
        for s in self.states:
            if s.actor == actor and s.name == name:
                return s
        raise KeyError((actor, name))

    def as_tuples(self) -> list[list[tuple[str, str]]]:
        """The paper's ``fsm = [[(actor, state), ...], ...]`` form."""
        return [[(c.actor, c.state) for c in st.conditions] for st in self.stages]


class Entity(Model):
    """An actor or object of the scenario, with its properties and motion primitive."""

    name: str  # unique in the scenario, e.g. 'ambulance1'
    asset: str  # asset database id, e.g. 'ambulance'
    kind: Literal["agent", "object", "robot"] = "agent"  # 'robot': the one whose behavior is explained
    properties: dict[str, str] = Field(default_factory=dict)  # e.g. {'siren': 'on'}
    behavior: str | None = None  # motion primitive id, e.g. 'drive_forward'
    behavior_params: dict[str, Scalar] = Field(default_factory=dict)

    @field_validator("kind", mode="before")
    @classmethod
    def _one_word_for_the_robot(cls, v: object) -> object:
        # scenario.json files written before every domain called its robot 'robot'
        return "robot" if v == "ego" else v

    @property
    def is_robot(self) -> bool:
        """Whether this is the robot whose behavior the scenario explains (kind 'robot')."""
        return self.kind == "robot"


class SolverReport(Model):
    status: Literal["optimal", "feasible", "infeasible", "model_invalid", "unknown", "not_run"] = "not_run"
    wall_time: float = 0.0  # [s]
    conflicts: list[str] = Field(default_factory=list)  # constraints named in an infeasible core
    relaxations: list[str] = Field(default_factory=list)  # placement constraints the solver relaxed, in words


class Scenario(Model):
    id: str
    domain: str  # a registered domain (regen.domains)
    behavior: Behavior
    causal_graph: list[str]  # event labels, root cause first, behavior last
    narrative: str
    entities: list[Entity]
    fsm: FSM
    parameters: dict[str, dict[str, Scalar]] = Field(default_factory=dict)  # per entity, solved
    world: dict[str, Scalar] = Field(default_factory=dict)  # map, duration [s], step [s], seed ...
    solver: SolverReport = Field(default_factory=SolverReport)
    # parts of the scenario that rules wrote because the model's answer was unusable, in words
    fallbacks: list[str] = Field(default_factory=list)
    # who wrote the FSM the verdict is about: the model, the domain's rules, or the model with
    # stages added by rules (e.g. the cause stages it left out)
    fsm_source: Literal["model", "rules", "model+rules"] = "rules"
    # what the cause's words name against what this scenario shows, when a model was asked at
    # grounding (rules are applied again at verification)
    fidelity: Fidelity | None = None

    @model_validator(mode="after")
    def _actors_known(self) -> Scenario:
        names = [e.name for e in self.entities]
        if len(set(names)) != len(names):
            raise ValueError(f"entity names repeat: {names}")
        known = set(names)
        for s in self.fsm.states:
            if s.actor not in known:
                raise ValueError(f"abstract state {s.name!r} belongs to unknown actor {s.actor!r}; "
                                 f"known actors: {sorted(known)}")
            for p in s.all_of:
                for a in p.args:
                    if a not in known:
                        raise ValueError(f"predicate {p} in state {s.name!r} names unknown actor "
                                         f"{a!r}; known actors: {sorted(known)}")
        return self

    def robot(self) -> Entity | None:
        """The entity whose behavior the scenario explains (kind 'robot'), if any."""
        return next((e for e in self.entities if e.is_robot), None)

    def entity(self, name: str) -> Entity:
        for e in self.entities:
            if e.name == name:
                return e
        raise KeyError(name)


W = TypeVar("W", bound="WorldSettings")


class WorldSettings(BaseModel):
    """Base of a domain's typed view of ``Scenario.world``: the keys the domain reads and writes
    as fields with their defaults; keys it does not know are kept as they are."""

    model_config = ConfigDict(extra="allow")

    @classmethod
    def of(cls: type[W], scenario: Scenario, *, required: tuple[str, ...] = ()) -> W:
        """The scenario's world settings; :class:`ConfigError` naming the scenario and the bad key
        (or a ``required`` one that is unset)."""
        from regen.errors import ConfigError

        try:
            world = cls.model_validate(scenario.world)
        except ValidationError as exc:
            bad = []
            for e in exc.errors():
                key = ".".join(str(x) for x in e["loc"])
                if e["type"] == "missing":
                    bad.append(f"world.{key} is missing")
                else:
                    bad.append(f"world.{key} = {e.get('input')!r} is not valid ({e['msg']})")
            raise ConfigError(f"scenario {scenario.id!r}: " + "; ".join(bad)) from None
        missing = [k for k in required if getattr(world, k, None) is None]
        if missing:
            raise ConfigError(f"scenario {scenario.id!r}: " + "; ".join(f"world.{k} is missing" for k in missing))
        return world

    def updated(self: W, **changes: Any) -> W:
        """A copy with ``changes`` applied and checked (a key set to None is left out)."""
        return type(self).model_validate({**self.model_dump(exclude_none=True), **changes})

    def as_world(self) -> dict[str, Any]:
        """As ``Scenario.world``: fields in their order (unset ones left out), then the other keys."""
        return self.model_dump(exclude_none=True)
