"""Pictures of failed behavior tests end at the failure: a second after it, then the last frame
is held; a test that failed over the whole episode shows all of it."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

pytest.importorskip("scenic")

from regen.core.behavior import Behavior  # noqa: E402
from regen.core.scenario import FSM, AbstractState, Entity, PredicateCall, Scenario, Stage, StateRef  # noqa: E402
from regen.core.trace import ActorTrack, Trace  # noqa: E402
from regen.driving.testing.failure_pictures import HOLD_S, failure_time, render_failure  # noqa: E402
from regen.harness.cases import CaseResult, RobotStage  # noqa: E402
from regen.media import HOLD_MS  # noqa: E402

DT = 0.1  # [s]
SECONDS = 10.0  # [s] the episode goes on long after the collision, as a simulation does


def _episode(map_path):
    t = np.round(np.arange(0, SECONDS + 1e-9, DT), 6)
    n = len(t)
    ego_x = np.minimum(-20 + 6 * t, 0.5)  # drives into the parked car at t = 3.4 s and stays there
    actors = {
        "ego": ActorTrack(asset="sedan", kind="ego", length=4.6, width=1.9, x=list(ego_x), y=[-1.75] * n,
                          heading=[0.0] * n, speed=[6.0 if x < 0.5 else 0.0 for x in ego_x]),
        "car1": ActorTrack(asset="sedan", length=4.6, width=1.9, x=[5.0] * n, y=[-1.75] * n, heading=[0.0] * n),
    }
    trace = Trace(dt=DT, times=list(t), actors=actors, meta={"map": "straight", "map_path": str(map_path)})
    state = AbstractState(name="braking", actor="ego", all_of=[PredicateCall(name="braking", args=["ego"])])
    scenario = Scenario(id="demo", domain="driving",
                        behavior=Behavior(text="the ego-vehicle stops abruptly", domain="driving"),
                        causal_graph=["the car ahead stops", "the ego-vehicle stops abruptly"], narrative="test",
                        entities=[Entity(name="ego", asset="sedan", kind="ego"), Entity(name="car1", asset="sedan")],
                        fsm=FSM(states=[state], stages=[Stage(conditions=[StateRef(actor="ego", state="braking")])]))
    return scenario, trace


def _gif_times(path) -> tuple[int, list[int]]:
    im = Image.open(path)
    durations = []
    for k in range(im.n_frames):
        im.seek(k)
        durations.append(im.info["duration"])
    return im.n_frames, durations


def test_a_collision_gif_ends_a_second_after_the_collision(straight_map, tmp_path):
    scenario, trace = _episode(straight_map)
    hit = 3.4
    case = CaseResult(scenario="01-demo", status="failed", cause="collision", collision=True,
                      collision_with="car1", collision_time=hit, message=f"collision with car1 at t = {hit} s",
                      robot_stages=[RobotStage(conditions=["braking"])])
    assert failure_time(trace, case) == hit
    out = render_failure(scenario, trace, case, tmp_path, policy="constant-speed")
    frames, durations = _gif_times(out)
    # 10 frames a simulated second up to the collision and one second after it, the first frame
    # at t = 0: not the 101 frames of the whole episode
    assert frames <= round((hit + HOLD_S) / DT) + 2
    assert frames >= round((hit + HOLD_S) / DT)
    assert durations[0] == 100 and durations[-1] == HOLD_MS
    last = Image.open(out)
    last.seek(frames - 1)
    top = np.asarray(last.convert("RGB"))[6:22, 6:200].astype(int)
    assert ((top[..., 0] > 180) & (top[..., 1] < 90)).sum() > 100  # the red 'collision with car1' tag


def test_a_stage_never_reached_shows_the_whole_episode(straight_map, tmp_path):
    scenario, trace = _episode(straight_map)
    case = CaseResult(scenario="01-demo", status="failed", cause="state_not_reached",
                      message="ego: braking was never reached", robot_stages=[RobotStage(conditions=["braking"])])
    assert failure_time(trace, case) is None
    frames, durations = _gif_times(render_failure(scenario, trace, case, tmp_path, policy="idm"))
    assert frames == trace.steps and durations[-1] == HOLD_MS
