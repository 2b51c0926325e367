"""Typed values that cross stage boundaries: behavior, graph, scenario, trace, verdict."""

from regen.core.behavior import Behavior, BehaviorParams
from regen.core.graph import CausePath, Decision, Edge, Node, PathEntity, ScenarioGraph
from regen.core.scenario import (
    FSM,
    AbstractState,
    Entity,
    PredicateCall,
    Scenario,
    SolverReport,
    Stage,
    StateRef,
    WorldSettings,
)
from regen.core.trace import ActorTrack, Trace
from regen.core.verdict import Verdict

__all__ = [
    "FSM",
    "AbstractState",
    "ActorTrack",
    "Behavior",
    "BehaviorParams",
    "CausePath",
    "Decision",
    "Edge",
    "Entity",
    "Node",
    "PathEntity",
    "PredicateCall",
    "Scenario",
    "ScenarioGraph",
    "SolverReport",
    "Stage",
    "StateRef",
    "Trace",
    "Verdict",
    "WorldSettings",
]
