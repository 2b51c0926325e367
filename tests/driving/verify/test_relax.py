from regen.core import (
    FSM,
    AbstractState,
    Behavior,
    Entity,
    PredicateCall,
    Scenario,
    Stage,
    StateRef,
)
from regen.core.trace import ActorTrack, Trace
from regen.verify.relax import relax_fsm
from regen.verify.relax import verify_with_relaxation as verify


def _scenario(stages):
    states = [
        AbstractState(name="braking", actor="ego", all_of=[PredicateCall(name="moving", args=["ego"])]),
        AbstractState(name="gone", actor="truck", all_of=[PredicateCall(name="far_from", args=["truck", "ego"],
                                                                       params={"distance": 30.0})]),
    ]
    return Scenario(id="s", domain="driving", behavior=Behavior(text="ego stops", domain="driving"),
                    causal_graph=["a", "b"], narrative="n",
                    entities=[Entity(name="ego", asset="ego", kind="ego"), Entity(name="truck", asset="truck")],
                    fsm=FSM(states=states, stages=stages))


def _trace():
    n = 40
    return Trace(dt=0.1, times=[i * 0.1 for i in range(n)], actors={
        "ego": ActorTrack(asset="ego", x=[0.0] * n, y=[0.0] * n, heading=[0.0] * n,
                          speed=[5.0] * 10 + [0.0] * 30),
        "truck": ActorTrack(asset="truck", x=[i * 2.0 for i in range(n)], y=[0.0] * n,
                            heading=[0.0] * n, speed=[20.0] * n)})


def test_simultaneous_stage_is_split_and_recorded():
    both = Stage(conditions=[StateRef(actor="ego", state="braking"), StateRef(actor="truck", state="gone")])
    sc = _scenario([both])
    verdict, relaxed = verify(sc, _trace())
    assert verdict.feasible and verdict.status == "verified_after_relaxation"
    assert "after relaxing 1 stage(s) of the FSM" in verdict.reason
    assert len(relaxed.fsm.stages) == 2
    assert relaxed.fsm.stages[0].conditions[0].state == "braking"  # held first, so comes first
    assert verdict.relaxations and "relaxed into 2 consecutive stages" in verdict.relaxations[0]


def test_no_relaxation_when_a_condition_never_holds():
    sc = _scenario([Stage(conditions=[StateRef(actor="truck", state="gone")]),
                    Stage(conditions=[StateRef(actor="ego", state="braking")])])
    verdict, _ = verify(sc, _trace())
    assert not verdict.feasible and verdict.first_unmet_stage == 2
    assert relax_fsm(sc.fsm, verdict) is None
