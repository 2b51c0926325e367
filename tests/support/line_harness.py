"""A tiny policy harness for the shared harness code: a robot 'r' on a line that must reach
x >= 5; touching the box at x = 8 is a collision. Subclasses give ``run_policy`` when they run
episodes."""

from __future__ import annotations

from regen.core.scenario import FSM, AbstractState, Entity, PredicateCall, Scenario, Stage, StateRef
from regen.core.trace import ActorTrack, Trace
from regen.harness.contract import Incident, PolicyHarness, TemplateRun


class LineHarness(PolicyHarness):
    robot = "robot"

    def load_policy(self, spec):
        raise NotImplementedError

    def action_to_wire(self, action):
        return [float(action)]

    def action_from_wire(self, data):
        return data[0]

    def prepare(self, scenario):
        return scenario

    def run_policy(self, prepared, policy, *, step_timeout):
        raise NotImplementedError

    def incidents(self, scenario, trace):
        x = trace.actors["r"].x
        hit = next((k for k, v in enumerate(x) if v >= 8.0), None)
        return [] if hit is None else [Incident("collision", trace.times[hit], hit, ("r", "box"),
                                                "r touched box", collision=True)]

    def sample_variants(self, scenario, n, seed, *, extremes=False):
        return [scenario]

    def check_template(self, scenario):
        return TemplateRun(verdict=None)


def line_scenario(sid: str = "s", causes: tuple[str, ...] = ()) -> Scenario:
    far = AbstractState(name="far", actor="r", all_of=[PredicateCall(name="moving", args=["r"])])
    fsm = FSM(states=[far], stages=[Stage(conditions=[StateRef(actor="r", state="far")])])
    return Scenario(id=sid, domain="line", behavior={"text": "it moves", "domain": "line"},
                    causal_graph=[*causes, "it moves"], narrative="",
                    entities=[Entity(name="r", asset="bot", kind="robot"), Entity(name="box", asset="box", kind="object")],
                    fsm=fsm)


def line_trace(xs: list[float]) -> Trace:
    n = len(xs)
    track = ActorTrack(asset="bot", x=xs, y=[0.0] * n, heading=[0.0] * n, speed=[1.0] * n, length=1.0, width=1.0)
    still = ActorTrack(asset="box", x=[8.5] * n, y=[0.0] * n, heading=[0.0] * n, speed=[0.0] * n, length=1.0, width=1.0)
    return Trace(dt=1.0, times=[float(k) for k in range(n)], actors={"r": track, "box": still})
