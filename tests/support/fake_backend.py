"""A tiny domain backend for pipeline tests (test double; the product uses the real simulators)."""

from __future__ import annotations

from pathlib import Path

from regen.contract import DomainBackend, SimulationOutput
from regen.core import (
    FSM,
    AbstractState,
    ActorTrack,
    Entity,
    PredicateCall,
    Scenario,
    Stage,
    StateRef,
    Trace,
)
from regen.driving.backend import DrivingBackend


class FakeBackend(DomainBackend):
    """Stands in for the driving simulator (same name, database and wording)."""

    name = "driving"
    database_resource = DrivingBackend.database_resource
    wording = DrivingBackend.wording
    predicates_module = DrivingBackend.predicates_module
    params_model = DrivingBackend.params_model
    params = DrivingBackend.params
    check_behavior = DrivingBackend.check_behavior
    settings_key = DrivingBackend.settings_key
    simulated: list[str] = []
    interrupt_on: str | None = None

    def ground(self, path, llm, *, seed=0):
        if "impossible" in path.events[0]:
            raise ValueError("cannot place this")
        ent = path.entities[0].asset
        fsm = FSM(states=[AbstractState(name="stopped", actor="ego",
                                        all_of=[PredicateCall(name="stopped", args=["ego"])])],
                  stages=[Stage(conditions=[StateRef(actor="ego", state="stopped")])])
        return Scenario(id=path.key, domain="driving", behavior=path.behavior, causal_graph=path.events,
                        narrative=f"A {ent} makes the ego stop.",
                        entities=[Entity(name="ego", asset="ego", kind="ego"), Entity(name="a1", asset=ent)],
                        fsm=fsm)

    def simulate(self, scenario, workdir: Path):
        if FakeBackend.interrupt_on and FakeBackend.interrupt_on in scenario.narrative:
            FakeBackend.interrupt_on = None
            raise KeyboardInterrupt
        FakeBackend.simulated.append(scenario.narrative)
        never_stops = "bus" in scenario.narrative
        speed = [5.0, 5.0, 5.0] if never_stops else [5.0, 2.0, 0.0]
        return SimulationOutput(trace=Trace(dt=0.5, times=[0.0, 0.5, 1.0], actors={
            "ego": ActorTrack(asset="ego", kind="ego", x=[0, 1, 2], y=[0, 0, 0], speed=speed),
            "a1": ActorTrack(asset="x", x=[5, 5, 5], y=[0, 0, 0], speed=[0, 0, 0])}))

    def render(self, scenario, trace, verdict, out_dir):
        return {}
