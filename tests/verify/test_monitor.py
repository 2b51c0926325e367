from __future__ import annotations

import numpy as np

from regen.core import (
    FSM,
    AbstractState,
    ActorTrack,
    Behavior,
    Entity,
    PredicateCall,
    Scenario,
    Stage,
    StateRef,
    Trace,
)
from regen.verify import check_fsm, validate_fsm


def _trace(ego_speed: list[float], amb_x: list[float]) -> Trace:
    n = len(ego_speed)
    return Trace(dt=1.0, times=[float(i) for i in range(n)], actors={
        "ego": ActorTrack(asset="ego", kind="ego", x=[0.0] * n, y=[0.0] * n, speed=ego_speed),
        "amb": ActorTrack(asset="ambulance", x=amb_x, y=[3.5] * n, speed=[10.0] * n,
                          states={"siren": ["on"] * n}),
    })


def _scenario(stages: list[list[tuple[str, str]]]) -> Scenario:
    states = [
        AbstractState(name="near", actor="amb", all_of=[PredicateCall(name="close_to", args=["amb", "ego"],
                                                                      params={"distance": 10.0})]),
        AbstractState(name="siren", actor="amb", all_of=[PredicateCall(name="state_is", args=["amb"],
                                                                       params={"key": "siren", "value": "on"})]),
        AbstractState(name="stopped", actor="ego", all_of=[PredicateCall(name="stopped", args=["ego"])]),
        AbstractState(name="driving", actor="ego", all_of=[PredicateCall(name="stopped", args=["ego"], negate=True)]),
    ]
    return Scenario(id="t", domain="driving", behavior=Behavior(text="stop", domain="driving"),
                    causal_graph=["amb", "stop"], narrative="",
                    entities=[Entity(name="ego", asset="ego", kind="ego"), Entity(name="amb", asset="ambulance")],
                    fsm=FSM(states=states, stages=[Stage(conditions=[StateRef(actor=a, state=s) for a, s in st])
                                                   for st in stages]))


def test_stages_reached_in_order_with_times() -> None:
    tr = _trace([10, 10, 5, 0, 0, 0], [-30, -20, -8, 0, 8, 20])
    v = check_fsm(_scenario([[("ego", "driving"), ("amb", "siren")], [("amb", "near")], [("ego", "stopped")]]), tr)
    assert v.feasible and v.status == "verified"
    assert [s.reached_at for s in v.stages] == [0.0, 2.0, 3.0]


def test_stage_order_matters() -> None:
    # the ego stops (t=3) before... then must be driving again: never happens
    tr = _trace([10, 10, 5, 0, 0, 0], [-30, -20, -8, 0, 8, 20])
    v = check_fsm(_scenario([[("ego", "stopped")], [("ego", "driving")]]), tr)
    assert not v.feasible and v.first_unmet_stage == 2
    assert "never held after the previous stage: ego: driving" in v.reason


def test_conditions_that_never_coincide_are_named_as_such() -> None:
    tr = _trace([10, 10, 10, 0, 0, 0], [-30, -20, -8, 0, 30, 40])
    # amb near at t=2,3 ; ego stopped from t=3 -> coincide at 3; shift so they never coincide
    tr.actors["amb"].x = [-30, -8, 0, 30, 40, 50]
    v = check_fsm(_scenario([[("amb", "near"), ("ego", "stopped")]]), tr)
    assert not v.feasible
    assert "never all at once" in v.reason
    assert v.stages[0].satisfied_alone == {"amb: near": 1.0, "ego: stopped": 3.0}


def test_unknown_predicate_is_an_invalid_scenario_not_a_crash() -> None:
    sc = _scenario([[("ego", "stopped")]])
    sc.fsm.states[2].all_of[0].name = "levitating"
    v = check_fsm(sc, _trace([0, 0], [0, 0]))
    assert not v.feasible and v.status == "invalid_scenario" and "unknown predicate 'levitating' for driving" in v.reason


def test_validate_fsm_reports_arity_and_params() -> None:
    sc = _scenario([[("ego", "stopped")]])
    sc.fsm.states[0].all_of[0].args = ["amb"]
    sc.fsm.states[0].all_of[0].params = {"radius": 3.0}
    problems = validate_fsm(sc.fsm, {"ego", "amb"}, "driving")
    assert any("takes 2 actor(s)" in p for p in problems)
    assert any("no parameter(s) ['radius']" in p for p in problems)


def test_predicates_are_vectorized_over_steps() -> None:
    from regen.verify import get_predicate

    tr = _trace([0.0, 0.2, 1.0], [0, 0, 0])
    out = get_predicate("moving", "driving").fn(tr, ["ego"], {"min_speed": 0.5})
    assert isinstance(out, np.ndarray) and out.tolist() == [False, False, True]


def _with_far(sc: Scenario, stages: list[list[tuple[str, str]]], *, cause: bool = False,
              source: str = "model") -> Scenario:
    """``sc`` plus a model state 'far' of amb that never holds (more than 100 m away)."""
    far = AbstractState(name="far", actor="amb", cause=cause, all_of=[
        PredicateCall(name="far_from", args=["amb", "ego"], params={"distance": 100.0})])
    fsm = FSM(states=[*sc.fsm.states, far],
              stages=[Stage(conditions=[StateRef(actor=a, state=s) for a, s in st]) for st in stages])
    return sc.model_copy(update={"fsm": fsm, "fsm_source": source})


def test_a_model_state_of_another_actor_that_never_holds_is_dropped_and_said() -> None:
    from regen.verify.relax import verify_with_relaxation

    tr = _trace([10, 10, 5, 0, 0, 0], [-30, -20, -8, 0, 8, 20])
    base = _scenario([])
    sc = _with_far(base, [[("ego", "driving")], [("amb", "near"), ("amb", "far")], [("ego", "stopped")]])
    assert check_fsm(sc, tr).status == "fsm_incomplete"
    v, judged = verify_with_relaxation(sc, tr)
    assert v.status == "verified_after_relaxation"
    assert v.relaxations and "dropped the model's state amb: far (far_from(amb, ego, distance=100" in v.relaxations[0]
    assert judged.fsm.as_tuples() == [[("ego", "driving")], [("amb", "near")], [("ego", "stopped")]]
    # never a cause state, a robot's state, or a state of a rule-written FSM
    for other in (_with_far(base, [[("ego", "driving")], [("amb", "far")], [("ego", "stopped")]], cause=True),
                  _with_far(base, [[("ego", "stopped")], [("ego", "driving")]]),  # the ego never drives again
                  _with_far(base, [[("ego", "driving")], [("amb", "far")], [("ego", "stopped")]], source="rules")):
        v, _ = verify_with_relaxation(other, tr)
        assert not v.feasible and v.relaxations == []
