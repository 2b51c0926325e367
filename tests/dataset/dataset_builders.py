"""Hand-built driving scenarios, traces, verdicts and run folders for the dataset tests."""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path

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
from regen.core.behavior import Behavior
from regen.core.io import write_json
from regen.core.verdict import Causal, ReferenceRun, StageResult, Verdict
from regen.runfolder import RunManifest, RunSettings

DT = 0.1
DURATION = 10.0
T_DECIDE = 5.0  # [s] when the ego's reaction stage is reached in every hand-built verdict
Motion = Callable[[float], tuple[float, float, float]]  # t -> (x, y, speed)


def steady(v: float, x0: float = 0.0, y: float = 0.0) -> Motion:
    return lambda t: (x0 + v * t, y, v)


def brake(v0: float, to: float, decel: float = 5.0, t0: float = T_DECIDE) -> Motion:
    """Speed v0 until t0, then braking at ``decel`` [m/s^2] down to ``to`` [m/s]."""
    def f(t: float) -> tuple[float, float, float]:
        if t <= t0:
            return v0 * t, 0.0, v0
        tb = min(t - t0, (v0 - to) / decel)
        v = v0 - decel * tb
        x = v0 * t0 + v0 * tb - decel * tb * tb / 2 + to * max(0.0, t - t0 - tb)
        return x, 0.0, v
    return f


def drive_off(v: float = 10.0, accel: float = 3.0, t0: float = T_DECIDE) -> Motion:
    def f(t: float) -> tuple[float, float, float]:
        if t <= t0:
            return 0.0, 0.0, 0.0
        ta = min(t - t0, v / accel)
        return accel * ta * ta / 2 + v * max(0.0, t - t0 - ta), 0.0, accel * ta
    return f


def lane_change(side: float, v: float = 10.0, width: float = 3.5, t0: float = T_DECIDE) -> Motion:
    """Straight at ``v``, moving ``side`` * ``width`` metres sideways (left positive) over 2 s after t0."""
    return lambda t: (v * t, side * width * min(1.0, max(0.0, (t - t0) / 2.0)), v)


def turn(side: float, v: float = 6.0, radius: float = 10.0, t0: float = T_DECIDE) -> Motion:
    """Straight along +x, then a quarter circle to the left (side=1) or right (side=-1)."""
    def f(t: float) -> tuple[float, float, float]:
        if t <= t0:
            return v * t, 0.0, v
        a = min((t - t0) * v / radius, math.pi / 2)
        x, y = v * t0 + radius * math.sin(a), side * radius * (1 - math.cos(a))
        rest = max(0.0, t - t0 - (math.pi / 2) * radius / v) * v
        return x, y + side * rest, v
    return f


def track(asset: str, kind: str, motion: Motion, times: list[float], states=None) -> ActorTrack:
    pts = [motion(t) for t in times]
    xs, ys, vs = [p[0] for p in pts], [p[1] for p in pts], [p[2] for p in pts]
    hs, last = [], 0.0
    for i in range(len(xs)):
        j, k = min(i + 1, len(xs) - 1), max(min(i + 1, len(xs) - 1) - 1, 0)
        if math.hypot(xs[j] - xs[k], ys[j] - ys[k]) > 1e-6:
            last = math.atan2(ys[j] - ys[k], xs[j] - xs[k])
        hs.append(last)
    return ActorTrack(asset=asset, kind=kind, length=4.6, width=1.9, height=1.5, x=xs, y=ys, heading=hs,
                      speed=vs, states=states or {})


def trace(ego: Motion, others: dict[str, tuple[str, str, Motion]] | None = None,
          states: dict[str, dict[str, list]] | None = None) -> Trace:
    times = [round(k * DT, 6) for k in range(int(DURATION / DT) + 1)]
    actors = {"ego": track("ego", "ego", ego, times)}
    for name, (asset, kind, m) in (others or {}).items():
        actors[name] = track(asset, kind, m, times, (states or {}).get(name))
    return Trace(dt=DT, times=times, actors=actors, meta={"simulator": "hand-built"})


def scenario(template: str | None, ego_states: list[tuple[str, list[PredicateCall]]] | None = None,
             cause: str = "car1", text: str = "the ego-vehicle stops abruptly", sid: str = "s1") -> Scenario:
    """A scenario whose FSM is: (cause moving, ego's first state), then one stage per reaction
    state. ``ego_states``: (first, *reaction) states; default: the template's own."""
    if ego_states is None:
        from regen.driving.world.egos.registry import EGO_TEMPLATES

        first, reaction = EGO_TEMPLATES[template].ego_states()
        ego_states = [first, *reaction]
    states = [AbstractState(name="near", actor=cause, cause=True,
                            all_of=[PredicateCall(name="close_to", args=[cause, "ego"])])]
    states += [AbstractState(name=n, actor="ego", all_of=calls) for n, calls in ego_states]
    stages = [Stage(conditions=[StateRef(actor=cause, state="near"), StateRef(actor="ego", state=ego_states[0][0])])]
    stages += [Stage(conditions=[StateRef(actor="ego", state=n)]) for n, _ in ego_states[1:]]
    world = {"ego_template": template} if template else {}
    return Scenario(id=sid, domain="driving", behavior=Behavior(text=text, domain="driving"),
                    causal_graph=[f"a {cause} cuts in ahead", text], narrative=f"The {cause} cuts in; the ego reacts.",
                    entities=[Entity(name="ego", asset="ego", kind="robot"), Entity(name=cause, asset="sedan")],
                    fsm=FSM(states=states, stages=stages), world=world)


def verdict(sc: Scenario, *, status: str = "verified", causal: str = "caused", reacts: bool = True) -> Verdict:
    """``reacts``: whether the reference driver shows the behavior in this world (its with-cause run)."""
    n = len(sc.fsm.stages)
    times = [1.0] + [T_DECIDE + 1.0 * k for k in range(n - 1)]
    stages = [StageResult(index=k + 1, conditions=[f"{c.actor}: {c.state}" for c in st.conditions],
                          reached_at=times[k]) for k, st in enumerate(sc.fsm.stages)]
    cause = next(s.actor for s in sc.fsm.states if s.cause)
    c = Causal(status=causal, reason=f"the reference driver stops for {cause}; without it it does not",
               by="reference driver (IDM)", behavior="stops", cause=[cause],
               with_cause=(ReferenceRun(shown=True, happened=True, summary="stops at t = 7.0 s") if reacts else
                           ReferenceRun(shown=False, happened=False, summary="never stops nor brakes to half its speed")),
               without_cause=ReferenceRun(removed=[cause], shown=False, happened=False,
                                          summary="never stops nor brakes to half its speed"))
    feasible = status in ("verified", "verified_after_relaxation")
    return Verdict(feasible=feasible, status=status, reason="hand-built", stages=stages, causal=c)


def write_scenario(folder: Path, sc: Scenario, tr: Trace, vd: Verdict) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    write_json(folder / "scenario.json", {"scenario": sc.model_dump(mode="json"), "config": {}})
    write_json(folder / "trace.json", tr)
    write_json(folder / "verdict.json", vd)


def stop_trace() -> Trace:
    return trace(brake(10.0, 0.0), {"car1": ("sedan", "agent", steady(8.0, x0=15.0))})


def write_run(root: Path) -> Path:
    """A run folder: a stop (caused), a stop whose cause is not sufficient, a stop whose trace
    never stops (contradiction), and a what-if of the first that removes the cause."""
    run = root / "run"
    names = ["01-a-car-cuts-in", "02-not-sufficient", "03-never-stops"]
    behavior = Behavior(text="the ego-vehicle stops abruptly", domain="driving")
    write_json(run / "run.json", RunManifest(behavior=behavior, settings=RunSettings(), status="done",
                                             scenarios=names))
    sc = scenario("stop_abruptly", sid="a1")
    write_scenario(run / "scenarios" / names[0], sc, stop_trace(), verdict(sc))
    sc2 = scenario("stop_abruptly", sid="b2")
    write_scenario(run / "scenarios" / names[1], sc2, stop_trace(), verdict(sc2, causal="not_sufficient"))
    sc3 = scenario("stop_abruptly", sid="c3")
    write_scenario(run / "scenarios" / names[2], sc3, trace(steady(10.0)), verdict(sc3))
    wi = run / "whatif" / f"{names[0]}-whatif-abc123"
    # the scripted ego of the what-if still brakes (it replays its reaction); the reference driver does not
    write_scenario(wi, sc, stop_trace(), verdict(sc, status="fsm_incomplete", causal="not_sufficient", reacts=False))
    write_json(wi / "whatif.json", {
        "original": str((run / "scenarios" / names[0]).resolve()), "edits": [{"op": "remove", "entity": "car1"}],
        "original_status": "verified", "status": "fsm_incomplete", "explained": False, "causal": "not_sufficient",
        "original_causal": "caused", "original_explained": True, "reason": "the ego never brakes"})
    return run
