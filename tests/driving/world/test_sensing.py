"""Sensing with effects: a jammed GNSS makes the ego perceive itself metres off, and the ego's
stop waits for that perceived error; with a nominal signal it never stops, and the verdict says
so. The trace carries the perceived error and position the ego reacted to."""

from __future__ import annotations

import json

import numpy as np
import pytest
from driving_chains import chain

from regen.driving.world.sensing import LIMITS, REACTION_DELAY, ego_clock, perceived_error

pytest.importorskip("scenic")


def test_the_ego_clock_holds_the_reaction_until_the_perceived_error_crosses_the_limit():
    sensing = (None, 5.0, 15.0, 30.0, 0.3, 2.0, 6.0, REACTION_DELAY)  # degrades at 5 s, event at 6 s
    reacted, t = None, None
    for k in range(100):
        now = k * 0.1
        reacted, t = ego_clock(sensing, reacted, now, now)
        if now < 5.0:
            assert reacted is None and t == min(now, 6.0 - 1e-3)
    assert reacted == pytest.approx(5.2)  # 0.3 m + 15 m/s passes 2 m after 0.14 s: the next step
    assert t == pytest.approx(6.0 + 9.9 - 5.2 - REACTION_DELAY)
    never = (None, 1e6, 0.0, 0.3, 0.3, 2.0, 6.0, REACTION_DELAY)
    assert ego_clock(never, None, 9.0, 9.0) == (None, 6.0 - 1e-3)
    assert perceived_error(-1.0, 15.0, 30.0, 0.3) == 0.3 and perceived_error(10.0, 15.0, 30.0, 0.3) == 30.0


def _run(tmp_path, signal: str):
    from regen.core.trace import Trace
    from regen.pipeline.stages import run_path

    path = chain("stop_abruptly", "GPS jamming corrupts the ego's position", ("gnss", {"gnss_signal": [signal]}))
    out = run_path(path, tmp_path / signal, pictures=signal == "jammed")
    return out, Trace.model_validate_json((tmp_path / signal / "trace.json").read_text())


@pytest.mark.slow
def test_a_jammed_gnss_makes_the_ego_stop_after_it_perceives_the_error(tmp_path):
    out, tr = _run(tmp_path, "jammed")
    assert out.verdict.feasible, out.verdict.reason
    gnss, ego = tr.actors["gnss1"], tr.actors["ego"]
    err = np.asarray(gnss.states["gnss_error"], dtype=float)
    k_cross = int(np.flatnonzero(err > LIMITS["gnss_signal"])[0])
    speed = np.asarray(ego.speed)
    k_brake = int(np.flatnonzero(np.diff(speed) < -0.2)[0])
    assert tr.times[k_brake] >= tr.times[k_cross] + REACTION_DELAY - 0.11  # it brakes because it perceived
    off = np.hypot(np.asarray(gnss.states["perceived_x"]) - ego.x, np.asarray(gnss.states["perceived_y"]) - ego.y)
    assert off[-1] == pytest.approx(30.0, abs=0.01) and off[0] == pytest.approx(0.3, abs=0.01)
    assert (tmp_path / "jammed" / "bird_eye.gif").exists()


@pytest.mark.slow
def test_with_a_nominal_signal_the_ego_never_stops_and_is_not_verified(tmp_path):
    out, tr = _run(tmp_path, "nominal")
    assert not out.verdict.feasible
    assert min(tr.actors["ego"].speed) > 9.0  # nothing it perceived made it brake
    verdict = json.loads((tmp_path / "nominal" / "verdict.json").read_text())
    assert verdict["status"] != "verified"


@pytest.mark.slow
def test_a_policy_under_test_observes_the_jammed_position_and_loses_the_view_ahead_in_glare():
    from regen.driving.grounding.rules import ground_rule_based
    from regen.driving.testing.loop import run_policy

    seen = []

    def policy(obs):
        seen.append((obs.t, obs.ego.x, obs.ego.y, [a.name for a in obs.actors]))
        return (0.0, 0.0)

    jam = ground_rule_based(chain("stop_abruptly", "GPS jamming", ("gnss", {"gnss_signal": ["jammed"]})))
    ep = run_policy(jam, policy, step_timeout=None)
    ego = ep.trace.actors["ego"]
    off = [abs(y - ego.y[k]) for k, (_, _, y, _) in enumerate(seen)]
    assert off[0] == pytest.approx(0.3, abs=1e-3) and max(off) == pytest.approx(30.0, abs=1e-3)
    assert all(abs(x - ego.x[k]) < 1e-6 for k, (_, x, _, _) in enumerate(seen))  # off to its left only
    seen.clear()
    glare = ground_rule_based(chain("stop_abruptly", "sun glare blinds the front camera while a truck is ahead",
                                    ("camera", {"camera_view": ["glare"]}),
                                    ("truck", {"behavior": ["drive_forward"], "start_location": ["ahead_same_lane"],
                                               "target_speed": ["slow"]})))
    tr = run_policy(glare, policy, step_timeout=None).trace
    truck, ego = tr.actors["truck1"], tr.actors["ego"]
    ahead = [truck.x[k] > ego.x[k] for k in range(len(seen))]
    truck_seen = [("truck1" in names) for _, _, _, names in seen]
    assert ahead[0] and truck_seen[0]  # seen ahead at first
    hidden = [k for k in range(len(seen)) if ahead[k] and not truck_seen[k]]
    lost = np.asarray(tr.actors["camera1"].states["view_lost"], dtype=float)
    assert hidden and all(lost[k] > 0.5 for k in hidden)  # hidden only while the glare blinds it
