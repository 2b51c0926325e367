"""The fixed library of predicates that abstract states are built from.

A predicate is project code, evaluated on a whole :class:`~regen.core.trace.Trace` at once: it
returns one boolean per step. The LLM only names predicates and their arguments; the names are
checked against this registry before anything runs.

A domain's own predicates live in the module its backend names (``predicates_module``); they are
registered with :func:`predicate`, imported lazily on first use, and must import nothing heavier
than numpy.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from regen.core.trace import Trace
from regen.errors import ConfigError

PredicateFn = Callable[[Trace, list[str], dict], np.ndarray]

SHARED = "*"  # the table of predicates that hold in every domain


@dataclass(frozen=True)
class PredicateSpec:
    name: str
    arity: int  # number of actor arguments
    doc: str  # one line, shown to the model and in the docs
    fn: PredicateFn
    domains: tuple[str, ...] = (SHARED,)  # SHARED: every domain
    params: dict[str, float | str] = field(default_factory=dict)  # name -> default

    def signature(self) -> str:
        args = ["a", "b", "c"][: self.arity]
        extra = [f"{k}={v}" for k, v in self.params.items()]
        return f"{self.name}({', '.join(args + extra)})"


# domain (or SHARED) -> name -> spec: a domain may use a shared name for its own meaning ('behind'
# on a road is about lanes and travel direction; on a table it is about the robot's view).
_REGISTRY: dict[str, dict[str, PredicateSpec]] = {SHARED: {}}
_LOADED: set[str] = set()


def predicate(name: str, arity: int, doc: str, *, domains: tuple[str, ...] = (SHARED,),
              params: dict[str, float | str] | None = None) -> Callable[[PredicateFn], PredicateFn]:
    """Register a predicate function under ``name`` for ``domains`` (default: every domain)."""

    def deco(fn: PredicateFn) -> PredicateFn:
        spec = PredicateSpec(name, arity, doc, fn, tuple(domains), dict(params or {}))
        for d in domains:
            table = _REGISTRY.setdefault(d, {})
            if name in table and table[name].fn is not fn:
                raise ValueError(f"predicate {name!r} is registered twice for domain {d!r}")
            table[name] = spec
        return fn

    return deco


def _load(domain: str) -> None:
    """Import the domain's predicate module (named by its backend) once."""
    if domain in _LOADED:
        return
    from regen import domains

    module = domains.backend_class(domain).predicates_module
    if module:
        importlib.import_module(module)
    _LOADED.add(domain)


def _table(domain: str) -> dict[str, PredicateSpec]:
    """The library of one domain: the shared predicates, overridden by the domain's own."""
    _load(domain)
    return {**_REGISTRY[SHARED], **_REGISTRY.get(domain, {})}


def list_predicates(domain: str | None = None) -> list[PredicateSpec]:
    """The library of a domain (or of every registered domain), sorted by name."""
    from regen import domains

    seen: dict[int, PredicateSpec] = {}
    for d in [domain] if domain else domains.names():
        for spec in _table(d).values():
            seen.setdefault(id(spec), spec)
    return sorted(seen.values(), key=lambda s: (s.name, s.domains))


def get_predicate(name: str, domain: str) -> PredicateSpec:
    """The predicate ``name`` of ``domain``; ConfigError naming the library when unknown."""
    spec = _table(domain).get(name)
    if spec is None:
        known = ", ".join(s.name for s in list_predicates(domain))
        raise ConfigError(f"unknown predicate {name!r} for {domain}; the library has: {known}")
    return spec


# --- helpers for predicate authors ------------------------------------------------------------


def arr(trace: Trace, actor: str, quantity: str) -> np.ndarray:
    """One quantity of one actor over all steps as a float array."""
    a = trace.actors[actor]
    seq = getattr(a, quantity) if quantity in ("x", "y", "z", "heading", "speed") else a.states[quantity]
    if not seq:
        return np.zeros(trace.steps)
    return np.asarray(seq, dtype=float)


def state(trace: Trace, actor: str, key: str) -> list:
    """A property state of an actor over all steps (``None`` where the actor has no such state)."""
    return trace.actors[actor].states.get(key, [None] * trace.steps)


def distance(trace: Trace, a: str, b: str) -> np.ndarray:
    """Centre-to-centre planar distance [m] per step."""
    return np.hypot(arr(trace, a, "x") - arr(trace, b, "x"), arr(trace, a, "y") - arr(trace, b, "y"))


# --- predicates that hold in every domain -----------------------------------------------------


@predicate("moving", 1, "the actor moves faster than min_speed [m/s]", params={"min_speed": 0.5})
def _moving(trace: Trace, args: list[str], params: dict) -> np.ndarray:
    return arr(trace, args[0], "speed") > float(params.get("min_speed", 0.5))


@predicate("stopped", 1, "the actor is (almost) at rest: speed below max_speed [m/s]",
           params={"max_speed": 0.3})
def _stopped(trace: Trace, args: list[str], params: dict) -> np.ndarray:
    return arr(trace, args[0], "speed") < float(params.get("max_speed", 0.3))


@predicate("close_to", 2, "the actors' centres are within distance [m] of each other",
           params={"distance": 10.0})
def _close_to(trace: Trace, args: list[str], params: dict) -> np.ndarray:
    return distance(trace, args[0], args[1]) <= float(params.get("distance", 10.0))


@predicate("far_from", 2, "the actors' centres are more than distance [m] apart",
           params={"distance": 30.0})
def _far_from(trace: Trace, args: list[str], params: dict) -> np.ndarray:
    return distance(trace, args[0], args[1]) > float(params.get("distance", 30.0))


@predicate("state_is", 1, "the actor's property `key` currently has `value` (e.g. siren = on)",
           params={"key": "", "value": ""})
def _state_is(trace: Trace, args: list[str], params: dict) -> np.ndarray:
    values = state(trace, args[0], str(params.get("key", "")))
    want = str(params.get("value", ""))
    return np.array([v is not None and str(v) == want for v in values], dtype=bool)
