"""A recorded trajectory as the ego: placed on a generated map, replayed exactly by the Scenic
program, causes timed to the detected event, the FSM checked on the replayed ego, and the CLI's
one-line refusals."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from typer.testing import CliRunner

from regen.core import Behavior, CausePath, PathEntity
from regen.driving.world.replay import ego_template, recorded_template, recording
from regen.driving.world.setting import DrivingParams
from regen.errors import ConfigError


def _write(path, t, x, y, **extra):
    cols = {"t": t, "x": x, "y": y, **extra}
    with open(path, "w") as fh:
        fh.write(",".join(cols) + "\n")
        for row in zip(*cols.values(), strict=True):
            fh.write(",".join(f"{v:.4f}" for v in row) + "\n")
    return path


def _stop(tmp_path, *, decel=5.0, t_brake=5.0, hz=10, noise=0.0, name="stop.csv"):
    rng = np.random.default_rng(1)
    t = np.arange(0.0, 12.0, 1.0 / hz)
    v = np.where(t < t_brake, 10.0, np.maximum(0.0, 10.0 - decel * (t - t_brake)))
    x = np.concatenate([[0.0], np.cumsum(v[:-1]) / hz])
    return _write(tmp_path / name, t + 100.0, x + rng.normal(0, noise, len(t)), rng.normal(0, noise, len(t)))


def _lane_change(tmp_path, side: str):
    t = np.arange(0.0, 12.0, 0.1)
    x = 10.0 * t
    shift = 3.5 * np.clip((t - 5.0) / 3.0, 0.0, 1.0)
    y = shift if side == "left" else -shift
    return _write(tmp_path / f"lc_{side}.csv", t, x, y)


def test_a_gentle_stop_is_placed_on_the_straight_map_with_states_it_can_meet(tmp_path):
    rec, det = recording(_stop(tmp_path, decel=3.0))
    assert det.behavior == "stop_abruptly" and rec.map == "straight" and rec.frame == "ego_start"
    assert rec.samples[0][:2] == (-150.0, -1.75) and len(rec.samples) == 120  # t - t0 at 0.1 s
    assert abs(rec.event_time - 5.0) <= 0.5  # the file's time starts at 100 s
    t = recorded_template(rec)
    assert t.replay and t.t_event == rec.event_time and t.stops and t.map == "straight"
    assert abs(t.speed_event - 10.0) < 0.3
    _, reactions = t.ego_states()
    braking = next(c for name, calls in reactions for c in calls if c.name == "braking")
    # the template's own threshold (4 m/s^2) is beyond a 3 m/s^2 stop; the recording's is not
    assert braking.params["min_decel"] <= 0.6 * 3.0 + 0.1


@pytest.mark.parametrize(("side", "lanes"), [("left", (1, 0)), ("right", (0, 1))])
def test_a_lane_change_starts_in_the_lane_it_leaves_and_its_states_follow_the_recording(tmp_path, side, lanes):
    rec, det = recording(_lane_change(tmp_path, side))
    assert det.behavior == f"change_lane_{side}"
    t = recorded_template(rec)
    initial, reactions = t.ego_states()
    start = next(c for c in initial[1] if c.name == "in_lane")
    end = next(c for _, calls in reactions for c in calls if c.name == "in_lane")
    assert (start.params["lane"], end.params["lane"]) == lanes
    assert t.ego_lane == lanes[0]


def test_a_behavior_carries_its_recording_and_resolves_to_the_replayed_template(tmp_path):
    rec, _ = recording(_stop(tmp_path))
    params = DrivingParams(ego_template="stop_abruptly", recorded=rec)
    t = ego_template("the ego-vehicle stops abruptly", params)
    assert t.replay == tuple(tuple(s) for s in rec.samples)
    assert not ego_template("the ego-vehicle stops abruptly", DrivingParams()).replay


def test_paths_that_fit_no_map_or_no_template_are_one_line(tmp_path):
    t = np.arange(0.0, 40.0, 0.1)
    v = np.where(t < 32.0, 12.0, np.maximum(0.0, 12.0 - 6.0 * (t - 32.0)))  # stops after 384 m
    with pytest.raises(ConfigError, match="straight map holds"):
        recording(_write(tmp_path / "long.csv", t, np.cumsum(v) * 0.1, 0.0 * t))
    # a plain left turn at 8 m/s: 40 m straight, a quarter circle of 20 m, 40 m straight
    s = 8.0 * t[:140]
    arc = 20 * math.pi / 2
    a = np.clip((s - 40) / 20, 0, math.pi / 2)
    x = np.where(s < 40, s, 40 + 20 * np.sin(a))
    y = np.where(s < 40, 0.0, 20 * (1 - np.cos(a))) + np.clip(s - 40 - arc, 0, None)
    with pytest.raises(ConfigError, match="no ego template drives"):
        recording(_write(tmp_path / "turn.csv", t[:140], x, y))
    with pytest.raises(ConfigError, match="off the road"):
        recording(_write(tmp_path / "off.csv", t, np.cumsum(v) * 0.1 - 200, 0 * t + 12.0), map_name="straight")


def _recorded_path(rec, cause: str, *entities) -> CausePath:
    text = "the ego-vehicle stops abruptly while driving forward"
    behavior = Behavior(text=text, domain="driving",
                        params={"ego_template": "stop_abruptly", "recorded": rec.model_dump(mode="json")})
    return CausePath(behavior=behavior, events=[cause, text],
                     entities=[PathEntity(asset=a, event=cause, properties=p) for a, p in entities])


@pytest.mark.slow
def test_the_ego_replays_the_recording_exactly_and_the_cause_meets_its_event(tmp_path):
    pytest.importorskip("scenic")
    from regen.core.trace import Trace
    from regen.pipeline.stages import run_path

    rec, _ = recording(_stop(tmp_path, decel=4.0, t_brake=7.0, noise=0.05))
    path = _recorded_path(rec, "a child runs across the road",
                          ("child", {"behavior": ["cross_the_road"], "start_location": ["roadside_ahead"]}))
    out = run_path(path, tmp_path / "run", pictures=False)
    assert out.verdict.feasible, out.verdict.reason
    tr = Trace.model_validate_json((tmp_path / "run" / "trace.json").read_text())
    ego = tr.actors["ego"]
    n = len(rec.samples)
    err = max(math.hypot(ego.x[k] - rec.samples[k][0], ego.y[k] - rec.samples[k][1]) for k in range(n))
    assert err < 1e-3, err  # exact, noise and all
    assert max(abs(ego.speed[k] - rec.samples[k][3]) for k in range(n)) < 1e-3
    # the child is on the road before the recorded event, not at the template's 6 s
    child = tr.actors["child1"] if "child1" in tr.actors else next(a for k, a in tr.actors.items() if k != "ego")
    on_road = [tr.times[k] for k in range(len(tr.times)) if abs(child.y[k]) < 7.0]
    assert on_road and on_road[0] < rec.event_time + 0.5
    scenario = json.loads((tmp_path / "run" / "scenario.json").read_text())["scenario"]
    assert scenario["behavior"]["params"]["recorded"]["source"] == "stop.csv"


@pytest.mark.parametrize(("args", "says"), [
    (["--ego-trajectory", "{bad}"], "is not a number"),
    (["--ego-trajectory", "{turn}"], "no ego template drives"),
    (["--map", "straight", "the ego-vehicle stops"], "give the file too"),
    ([], "give the behavior as text"),
    (["--ego", "slow_down", "--ego-trajectory", "{stop}"], "give one"),
])
def test_generate_refuses_bad_recordings_in_one_line_before_any_model_call(tmp_path, args, says):
    from regen.cli import app

    bad = tmp_path / "bad.csv"
    bad.write_text("t,x,y\n0,0,0\n0.1,oops,0\n0.2,2,0\n")
    t = np.arange(0.0, 14.0, 0.1)
    s = 8.0 * t
    a = np.clip((s - 40) / 20, 0, math.pi / 2)
    turn = _write(tmp_path / "turn.csv", t, np.where(s < 40, s, 40 + 20 * np.sin(a)),
                  np.where(s < 40, 0.0, 20 * (1 - np.cos(a))) + np.clip(s - 40 - 10 * math.pi, 0, None))
    files = {"bad": bad, "turn": turn, "stop": _stop(tmp_path)}
    args = [a.format(**files) for a in args]
    res = CliRunner().invoke(app, ["generate", "-d", "driving", "--out", str(tmp_path / "run"), "--replay", *args])
    assert res.exit_code == 2, res.output
    assert says in res.output and "Traceback" not in res.output
    assert not (tmp_path / "run" / "run.json").exists()
