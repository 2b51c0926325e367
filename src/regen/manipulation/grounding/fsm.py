"""The FSM of a grounded manipulation scenario, assembled from the predicate library.

Stage 1: the context holds and the furniture is in its initial state; stage 2: the hand
reaches the handle (or item); stage 3: the behavior's success predicates hold while the context
still holds.
"""

from __future__ import annotations

from regen.core.scenario import FSM, AbstractState, PredicateCall, Stage, StateRef
from regen.manipulation.grounding.placement import Request
from regen.manipulation.world.furniture import furniture
from regen.manipulation.world.tasks import BehaviorDef

_PRED = {"on": "on", "in": "inside", "under": "under", "near": "near", "left_of": "left_of",
         "right_of": "right_of", "in_front_of": "in_front_of", "behind": "behind",
         "outside": "outside", "out_of_reach": "out_of_reach"}


def relation_call(obj: str, relation: str, reference: str) -> PredicateCall:
    """The predicate that checks a placement relation on a trace."""
    if relation == "out_of_reach":
        return PredicateCall(name="out_of_reach", args=[obj, "robot"], params={"reach": 0.9})
    params = {"distance": 0.45} if relation == "near" else {}
    return PredicateCall(name=_PRED[relation], args=[obj, reference], params=params)


def build_fsm(behavior: BehaviorDef, fname: str, item: str | None, requests: list[Request]) -> FSM:
    """Stages: context in place and furniture in its initial state; the hand at the handle or
    item; the behavior's success predicates with the context still in place."""
    states: list[AbstractState] = []
    first: list[StateRef] = []
    last: list[StateRef] = []
    for r in requests:
        # the context is the cause: it holds before the robot acts (stage 1) and still at the end
        states.append(AbstractState(name="placed", actor=r.name, cause=True,
                                    all_of=[relation_call(r.name, r.relation, r.reference)]))
        first.append(StateRef(actor=r.name, state="placed"))
        last.append(StateRef(actor=r.name, state="placed"))
    spec = furniture(behavior.furniture)
    if spec.joint is not None:
        if behavior.start_fraction <= 0.05:
            call = PredicateCall(name="joint_closed", args=[fname], params={"at_most": 0.1})
        else:
            call = PredicateCall(name="joint_open", args=[fname],
                                 params={"at_least": round(behavior.start_fraction - 0.1, 3)})
        states.append(AbstractState(name="initial", actor=fname, all_of=[call]))
        first.append(StateRef(actor=fname, state="initial"))
    reach_target = item if behavior.script == "pick_place" and item else fname
    states.append(AbstractState(name="reaching", actor="robot", all_of=[
        PredicateCall(name="ee_near", args=["robot", reach_target], params={"distance": 0.08})]))
    subst = {"F": fname, "I": item or fname, "robot": "robot"}
    done = [c.model_copy(update={"args": [subst[a] for a in c.args]}) for c in behavior.success]
    states.append(AbstractState(name="task_done", actor="robot", all_of=done))
    last.insert(0, StateRef(actor="robot", state="task_done"))
    stages = []
    if first:
        stages.append(Stage(conditions=first))
    stages.append(Stage(conditions=[StateRef(actor="robot", state="reaching")]))
    stages.append(Stage(conditions=last))
    return FSM(states=states, stages=stages)


__all__ = ["build_fsm", "relation_call"]
