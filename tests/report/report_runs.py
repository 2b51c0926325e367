"""Builders of run-folder pieces from the real pydantic models (shared by the report tests)."""

from __future__ import annotations

from pathlib import Path

from PIL import Image

from regen.core.behavior import Behavior
from regen.core.scenario import (
    FSM,
    AbstractState,
    Entity,
    PredicateCall,
    Scenario,
    SolverReport,
    Stage,
    StateRef,
)
from regen.core.verdict import StageResult, Verdict

HOSTILE = "</script><script>alert(1)</script> \"q\" 'a' & <b>bold</b>"


def make_scenario(n: int, *, narrative: str = "A car brakes ahead of the ego.",
                  agent_name: str = "car1",
                  behavior_text: str = "the ego-vehicle stops abruptly") -> Scenario:
    behavior = Behavior(text=behavior_text, domain="driving", params={"ego_template": "stop_abruptly"})
    return Scenario(
        id=f"s{n}", domain="driving", behavior=behavior,
        causal_graph=[f"cause {n}", "a car cuts in", behavior.text],
        narrative=narrative,
        entities=[Entity(name="ego", asset="ego_car", kind="ego", behavior="stop_abruptly"),
                  Entity(name=agent_name, asset="ambulance", properties={"siren": "on"},
                         behavior="cut_in", behavior_params={"gap": 7.5})],
        fsm=FSM(states=[
            AbstractState(name="ahead", actor=agent_name,
                          all_of=[PredicateCall(name="in_front_of", args=[agent_name, "ego"],
                                                params={"distance": 10.0})]),
            AbstractState(name="stopped", actor="ego",
                          all_of=[PredicateCall(name="stopped", args=["ego"])]),
        ], stages=[Stage(conditions=[StateRef(actor=agent_name, state="ahead")]),
                   Stage(conditions=[StateRef(actor=agent_name, state="ahead"),
                                     StateRef(actor="ego", state="stopped")])]),
        parameters={agent_name: {"speed": 12.345678, "offset": 3.0}},
        world={"map": "straight", "duration": 20.0},
        solver=SolverReport(status="optimal", wall_time=0.12,
                            relaxations=["widened the gap range to 5-15 m"]),
    )


def verified(agent_name: str = "car1") -> Verdict:
    c1, c2 = f"{agent_name}: ahead", "ego: stopped"
    return Verdict(feasible=True, status="verified", reason="all 2 stages reached in order; accepted at t=6.4 s",
                   stages=[StageResult(index=1, conditions=[c1], reached_at=2.5, satisfied_alone={c1: 2.5}),
                           StageResult(index=2, conditions=[c1, c2], reached_at=6.4,
                                       satisfied_alone={c1: 2.5, c2: 6.4})])


def incomplete(agent_name: str = "car1") -> Verdict:
    c1, c2 = f"{agent_name}: ahead", "ego: stopped"
    return Verdict(feasible=False, status="fsm_incomplete",
                   reason="stage 2 (car1: ahead; ego: stopped) was not reached: never held after the "
                          "previous stage: ego: stopped",
                   stages=[StageResult(index=1, conditions=[c1], reached_at=2.5, satisfied_alone={c1: 2.5}),
                           StageResult(index=2, conditions=[c1, c2], satisfied_alone={c1: 3.75, c2: None})],
                   first_unmet_stage=2)


def tiny_png(path: Path, size: tuple[int, int] = (40, 20)) -> None:
    Image.new("RGB", size, (30, 120, 200)).save(path)


def tiny_gif(path: Path) -> None:
    frames = [Image.new("P", (32, 24), c) for c in (1, 2, 3)]
    frames[0].save(path, save_all=True, append_images=frames[1:], duration=100, loop=0)
