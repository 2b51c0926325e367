"""Reactive triggers: the fire function, the time warp, and scenarios that unfold in front of a
slower and a faster ego driven by a policy (real Scenic Newtonian simulator): a child crosses, a
door opens, a car cuts in or changes into the ego's lane."""

from __future__ import annotations

import dataclasses

import pytest
from driving_chains import FEASIBLE, chain  # noqa: E402

from regen.driving.world.egos import EGO_TEMPLATES  # noqa: E402
from regen.driving.world.triggers import (  # noqa: E402
    Trigger,
    approach,
    ego_slower,
    fire_times,
    offset_reached,
    scenic_source,
    template_position,
    trigger_fired,
    warped_time,
)

# a point 40 m ahead of an ego at the origin heading +x; template: 40 m / 10 m/s = 4 s away
NEAR = Trigger(kind="approach", t=3.0, x=40.0, y=-1.75, distance=40.0, tta=4.0).spec()


def test_approach_fires_by_distance_for_a_slow_ego() -> None:
    assert not trigger_fired(NEAR, 9.0, -0.5, -1.75, 3.0)  # 40.5 m away, 13.5 s to go
    assert trigger_fired(NEAR, 9.0, 0.0, -1.75, 3.0)  # 40 m: the template's distance
    assert trigger_fired(NEAR, 9.0, 2.0, 0.0, 0.0)  # a standing ego as near (38 m ahead + 1.75 aside)
    assert not trigger_fired(NEAR, 9.0, 0.0, 0.0, 0.0)  # (41.75 m to go)


def test_approach_fires_by_time_to_arrival_for_a_fast_ego() -> None:
    assert trigger_fired(NEAR, 1.0, -16.0, -1.75, 14.0)  # 56 m at 14 m/s: 4 s to arrival
    assert not trigger_fired(NEAR, 1.0, -17.0, -1.75, 14.0)  # 57 m: 4.07 s
    assert not trigger_fired(NEAR, 1.0, -17.0, -1.75, 0.3)  # too slow for a time to arrival


def test_approach_fires_once_the_ego_has_passed_the_point() -> None:
    tight = Trigger(kind="approach", t=3.0, x=40.0, y=0.0, distance=1.0, tta=0.0).spec()
    assert not trigger_fired(tight, 0.0, 39.5, 5.0, 0.0)  # 0.5 m ahead, 5 m aside
    assert trigger_fired(tight, 0.0, 40.5, 5.0, 0.0)  # passed, in another lane


def test_time_and_ego_slower_kinds() -> None:
    at = Trigger(kind="time", t=2.8).spec()
    assert not trigger_fired(at, 2.7, 1e3, 0.0, 30.0) and trigger_fired(at, 2.8, -1e3, 0.0, 0.0)
    slower = Trigger(kind="ego_slower", t=6.8, below=5.0).spec()
    assert not trigger_fired(slower, 9.0, 0.0, 0.0, 5.0) and trigger_fired(slower, 0.0, 0.0, 0.0, 4.9)


def test_offset_fires_when_the_actor_reaches_its_template_offset_from_its_side() -> None:
    gains = Trigger(kind="offset", t=3.0, offset=5.0, rate=3.0, late=6.0).spec()  # pulls 5 m ahead
    assert not trigger_fired(gains, 3.0, 0.0, 0.0, 10.0, 4.9, -3.5)  # 4.9 m ahead
    assert trigger_fired(gains, 0.1, 0.0, 0.0, 10.0, 5.0, -3.5)  # 5 m ahead, any time
    closes = Trigger(kind="offset", t=3.0, offset=30.0, rate=-2.0, late=6.0).spec()  # the ego closes in
    assert not trigger_fired(closes, 3.0, 0.0, 0.0, 10.0, 30.1, -3.5)
    assert trigger_fired(closes, 3.0, 0.0, 0.0, 10.0, 29.0, -3.5)
    assert trigger_fired(closes, 6.0, 0.0, 0.0, 10.0, 80.0, -3.5)  # late: fires whatever the offset
    assert not trigger_fired(closes, 5.9, 0.0, 0.0, 10.0)  # without the actor's position: at late
    ego = EGO_TEMPLATES["slow_down"]  # at 12 m/s from s = -150 m
    trig = offset_reached(ego, -100.0, 3.0, 2.0)
    assert (trig.kind, trig.offset, trig.late) == ("offset", -100.0 - (-150.0 + 24.0), 5.0)


def test_time_warp_holds_then_runs_from_the_trigger_time() -> None:
    assert warped_time(None, None, 7.0, 0.0, 0.0, 0.0) == (None, 7.0)  # no trigger: absolute time
    assert warped_time(NEAR, None, 1.0, -100.0, -1.75, 10.0) == (None, 1.0)  # early part as scheduled
    t_fire, held = warped_time(NEAR, None, 5.0, -100.0, -1.75, 5.0)
    assert t_fire is None and 2.99 < held < 3.0  # held just before t_trig
    t_fire, now = warped_time(NEAR, None, 5.0, 0.0, -1.75, 5.0)
    assert t_fire == 5.0 and now == 3.0
    assert warped_time(NEAR, 5.0, 6.5, 1e3, 0.0, 0.0) == (5.0, 4.5)  # latched: t_trig + (t - t_fire)
    # step by step over a track: fires at the first step the ego is within 40 m
    assert fire_times(NEAR, [0.0, 1.0, 2.0], [-30.0, -10.0, 5.0], [-1.75] * 3, [1.0] * 3) == [0.0, 1.0, 3.0]


def test_template_ego_fires_at_the_trigger_time() -> None:
    """Built from a template, an approach trigger fires for that template at t, not a step before."""
    for tid in ("stop_abruptly", "stop_after_turn", "stop_in_intersection"):
        ego = EGO_TEMPLATES[tid]
        point = ego.frame.point(ego.s_event + 15.0, ego.frame.lane_d(ego.ego_lane))
        trig = approach(ego, point, 4.0)
        assert trig.kind == "approach"
        for t, fires in ((3.9, False), (4.0, True)):
            x, y = template_position(ego, t)
            assert trigger_fired(trig.spec(), t, x, y, ego.speed_event) is fires, (tid, t)
    waits = EGO_TEMPLATES["drive_forward"]
    assert approach(waits, (0.0, 0.0), 2.0) == Trigger(kind="time", t=2.0)
    assert ego_slower(EGO_TEMPLATES["stop_abruptly"]).below == 5.0


def test_scenic_program_carries_the_same_functions() -> None:
    source = scenic_source()
    assert "def trigger_fired(" in source and "def warped_time(" in source
    space: dict = {}
    exec(compile(source, "<scenic_source>", "exec"), space)  # plain Python, no imports
    assert space["trigger_fired"](NEAR, 0.0, 0.0, -1.75, 10.0)


# --- scenarios with a policy in the loop -----------------------------------------------------


def _hold(speed: float):
    """A test policy: hold ``speed`` [m/s] along the route, ignore everything else."""
    from regen.driving.testing.policies import Action, route_curvature

    def policy(obs):
        return Action(1.5 * (speed - obs.ego.speed), route_curvature(obs.ego))

    return policy


def _absolute(prepared):
    """The same scenario with every trigger removed (absolute timing, as before triggers)."""
    from regen.driving.simulation.program import write_program
    from regen.driving.simulation.run import compile_program

    plans = [dataclasses.replace(p, trigger=None, lane_change=None) for p in prepared.plans]
    text = write_program(plans, map_path=prepared.map_path, dt=prepared.dt, max_steps=prepared.steps)
    return dataclasses.replace(prepared, plans=plans, compiled=compile_program(text))


# a slower car ahead in the next lane changes into the ego's lane, 1 to 3 s before the ego brakes
CHANGES_IN = chain("stop_abruptly", "a car changes into the ego's lane",
                   ("sedan", {"behavior": ["change_lane"], "start_location": ["ahead_adjacent_lane"],
                              "target_speed": ["moderate"]}))


@pytest.fixture(scope="module")
def grounded(tmp_path_factory):
    """name -> a prepared verified scenario (rule-based grounding, no pictures)."""
    pytest.importorskip("scenic")
    from regen.driving.testing.loop import prepare
    from regen.pipeline import run_path
    from regen.runfolder import RunFolder

    out = {}
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("REGEN_CACHE_DIR", str(tmp_path_factory.mktemp("cache")))
        run = tmp_path_factory.mktemp("run")
        for name, path in (("child", FEASIBLE["stop_abruptly"][0]), ("door", FEASIBLE["stop_abruptly"][3]),
                           ("cut_in", FEASIBLE["slow_down"][2]), ("change_lane", CHANGES_IN)):
            folder = run / RunFolder.SCENARIOS / name
            outcome = run_path(path, folder, pictures=False)
            assert outcome.verdict.feasible, outcome.verdict.reason
            out[name] = prepare(RunFolder(run).scenario(name).scenario())
    return out


def _crossing_steps(prepared, trace) -> list[int]:
    """Steps at which the FSM's cause state holds: the child moves in the ego's lane, ahead of it."""
    from regen.verify.monitor import evaluate_state

    fsm = prepared.scenario.fsm
    state = next(s for s in fsm.states if s.actor == "child1" and s.name == "crossing")
    return [k for k, ok in enumerate(evaluate_state(state, trace, "driving")) if ok]


@pytest.mark.slow
def test_child_crosses_in_front_of_a_slower_and_a_faster_ego(grounded) -> None:
    from regen.driving.testing.loop import run_policy

    prep = grounded["child"]
    child = next(p for p in prep.plans if p.name == "child1")
    trig = child.trigger
    assert trig is not None and trig.kind == "approach"
    v = prep.template.speed_event
    for factor in (0.6, 1.4):
        trace = run_policy(prep, _hold(factor * v)).trace
        ego, kid = trace.actors["ego"], trace.actors["child1"]
        crossing = _crossing_steps(prep, trace)
        assert crossing, f"{factor}x: the child never crossed in front of the ego"
        k = crossing[0]
        assert kid.x[k] - ego.x[k] > 5.0 and kid.speed[k] > 0.3
        start = next(i for i, s in enumerate(kid.speed) if s > 0.3)  # (moves the step after it fires)
        fired = start - 1
        gap = trig.x - ego.x[fired]
        if factor < 1:  # a slower ego sets it off later, at the template's distance
            assert trace.times[fired] > trig.t + 1.0
            assert trig.distance - 1.0 < gap <= trig.distance + 1e-3
        else:  # a faster one earlier, further away: at the template's time to arrival
            assert trace.times[fired] < trig.t - 1.0
            assert gap > trig.distance + 5.0
            assert gap / ego.speed[fired] == pytest.approx(trig.tta, abs=0.15)
    # with absolute timing the fast ego is past the crossing before the child reaches its lane
    fast = run_policy(_absolute(prep), _hold(1.4 * v)).trace
    assert _crossing_steps(prep, fast) == []


@pytest.mark.slow
def test_door_opens_as_a_slower_ego_comes_near_and_the_policy_sees_it_when_recorded(grounded) -> None:
    from regen.driving.testing.loop import run_policy

    prep = grounded["door"]
    car = next(p for p in prep.plans if p.states.get("door"))
    assert car.trigger is not None and car.trigger.kind == "approach"
    seen: list[str | None] = []
    hold = _hold(0.6 * prep.template.speed_event)

    def watching(obs):
        seen.append(next(a.door for a in obs.actors if a.name == car.name))
        return hold(obs)

    trace = run_policy(prep, watching).trace
    door = trace.actors[car.name].states["door"]
    k = door.index("open")
    assert trace.times[k] > car.trigger.t + 1.0  # later than the template's absolute time
    ego = trace.actors["ego"]
    to_go = (car.x - ego.x[k]) + abs(car.y - ego.y[k])  # ahead + aside, as the trigger measures
    assert car.trigger.distance - 1.0 < to_go <= car.trigger.distance + 1e-3
    assert seen == door[:len(seen)]  # what the policy observed is what the trace recorded


def _cause_steps(prepared, trace, actor: str) -> list[list[int]]:
    """Per cause state of ``actor`` in the FSM (in order), the steps at which it holds."""
    from regen.verify.monitor import evaluate_state

    states = [s for s in prepared.scenario.fsm.states if s.actor == actor]
    assert len(states) == 2, [s.name for s in states]  # in the next lane, then in the ego's lane ahead
    return [[k for k, ok in enumerate(evaluate_state(s, trace, "driving")) if ok] for s in states]


def _changes_in_ahead(prepared, trace, actor: str) -> bool:
    """Whether ``actor``'s cause states hold in order and it is then in the ego's lane, ahead."""
    before, after = _cause_steps(prepared, trace, actor)
    if not before or not after or after[-1] <= before[0]:
        return False
    ego, car = trace.actors["ego"], trace.actors[actor]
    k = next(k for k in after if k > before[0])
    return car.states["lane"][k] == ego.states["lane"][k] and car.x[k] - ego.x[k] > 3.0


@pytest.mark.slow
@pytest.mark.parametrize("name", ["cut_in", "change_lane"])
def test_lane_change_lands_ahead_of_a_slower_and_a_faster_ego(grounded, name) -> None:
    from regen.driving.testing.loop import run_policy

    prep = grounded[name]
    car = next(p for p in prep.plans if p.lane_change is not None)
    assert car.trigger is not None and car.trigger.kind == "offset"
    v = prep.template.speed_event
    landed = {}
    for factor in (0.6, 1.4):
        trace = run_policy(prep, _hold(factor * v)).trace
        assert _changes_in_ahead(prep, trace, car.name), f"{factor}x: {car.name} did not change in ahead"
        landed[factor] = _cause_steps(prep, trace, car.name)[1][0]
    assert landed[0.6] > landed[1.4]  # later in front of the slower ego, earlier in front of the faster
    # at its fixed place and time, it lands beside or behind the faster ego or far ahead of the slower
    fixed = _absolute(prep)
    assert not all(_changes_in_ahead(prep, run_policy(fixed, _hold(f * v)).trace, car.name) for f in (0.6, 1.4))


def test_template_ego_meets_the_lane_change_of_its_fixed_route(grounded) -> None:
    """For the template ego the lane change laid out at the trigger is the fixed route's, to the bit."""
    from regen.driving.grounding.rules import plans_for
    from regen.driving.simulation.program import write_program
    from regen.driving.simulation.run import run_program

    prep = grounded["cut_in"]
    _, plans = plans_for(prep.scenario)
    runs = []
    for ps in (plans, [dataclasses.replace(p, trigger=None, lane_change=None) for p in plans]):
        text = write_program(ps, map_path=prep.map_path, dt=prep.dt, max_steps=prep.steps)
        runs.append(run_program(text, steps=prep.steps, dt=prep.dt))
    laid_out, fixed = runs
    car = next(p.name for p in plans if p.lane_change is not None)
    assert laid_out.y[car] == fixed.y[car] and laid_out.x[car] == fixed.x[car]
    assert min(laid_out.y[car]) < max(laid_out.y[car]) - 3.0  # it did change lanes
