"""ManipulationHarness through the contract methods, in real PyBullet: the scripted policy
passes, random and ramming policies fail with incidents, faults end episodes, variants differ."""

from __future__ import annotations

import numpy as np
import pytest
from manipulation_chains import door_scenario

from regen import domains
from regen.errors import ConfigError
from regen.harness.contract import PolicyHarness
from regen.manipulation.testing.harness import DISPLACE_TOL, ManipulationHarness
from regen.manipulation.testing.types import MAX_STEP, Action
from regen.verify.monitor import evaluate_state


def _oracle_ok(h: PolicyHarness, scenario, trace) -> bool:
    """The oracle stages reached in order, as the shared runner checks them."""
    start = 0
    for stage in h.oracle_stages(scenario):
        mask = np.ones(trace.steps, dtype=bool)
        for ref in stage:
            mask &= evaluate_state(scenario.fsm.state(ref.actor, ref.state), trace, scenario.domain)
        hit = np.flatnonzero(mask[start:])
        if not hit.size:
            return False
        start += int(hit[0])
    return True


def _ram(name: str):
    """Drive the hand straight at ``name`` at full speed."""
    def policy(obs):
        d = np.asarray(obs.object(name).position) - np.asarray(obs.robot.ee_position)
        return Action(*(d / max(np.linalg.norm(d), 1e-6) * MAX_STEP))
    return policy


def _episode(h, scenario, policy, timeout=1.0):
    return h.run_policy(h.prepare(scenario), policy, step_timeout=timeout)


def test_backend_returns_the_harness():
    h = domains.make("manipulation").policy_harness()
    assert isinstance(h, ManipulationHarness)
    assert {"scripted", "random", "sac"} <= set(h.builtin)


def test_oracle_drops_the_robots_approach_but_keeps_the_goal_and_context(harness, pet_in_reach):
    stages = [[(c.actor, c.state) for c in st] for st in harness.oracle_stages(pet_in_reach)]
    assert ("robot", "reaching") not in sum(stages, [])
    assert ("robot", "task_done") in stages[-1] and ("pet1", "placed") in stages[-1]
    assert ("door1", "initial") in stages[0]


def test_scripted_passes(harness, pet_in_reach):
    ep = _episode(harness, pet_in_reach, harness.load_policy("scripted"))
    assert ep.failure is None
    assert _oracle_ok(harness, pet_in_reach, ep.trace)
    assert harness.incidents(pet_in_reach, ep.trace) == []
    m = harness.metrics(pet_in_reach, ep.trace)
    assert m["goal_time"] is not None and m["max_displacement"] < DISPLACE_TOL


def test_random_fails_with_a_reason(harness, pet_in_reach):
    ep = _episode(harness, pet_in_reach, harness.load_policy("random"))
    assert not _oracle_ok(harness, pet_in_reach, ep.trace)
    kinds = [i.kind for i in harness.incidents(pet_in_reach, ep.trace)]
    assert "time_budget" in kinds


def test_ramming_the_pet_is_a_collision(harness, pet_in_reach):
    ep = _episode(harness, pet_in_reach, _ram("pet1"))
    incidents = harness.incidents(pet_in_reach, ep.trace)
    hit = [i for i in incidents if i.kind == "collision"]
    assert hit and hit[0].collision and hit[0].actors == ("robot", "pet1")
    assert "pet1" in hit[0].message
    # the trace says when: the robot's recorded contacts name the pet from that sample on
    assert "pet1" in ep.trace.actors["robot"].states["contacts"][hit[0].step]
    # a free 8 kg pet is pushed away: displaced beyond the tolerance
    assert any(i.kind in ("displaced", "knocked_over") and "pet1" in i.actors for i in incidents)


def test_ramming_a_plant_displaces_it(harness):
    sc = door_scenario({"plant1": ("right_of", "robot")}, ["plant"])
    ep = _episode(harness, sc, _ram("plant1"))
    incidents = harness.incidents(sc, ep.trace)
    assert not any(i.kind == "collision" for i in incidents)  # a plant is not a person or pet
    moved = [i for i in incidents if i.kind in ("displaced", "knocked_over")]
    assert moved and moved[0].actors == ("robot", "plant1")


@pytest.mark.parametrize("bad, kind", [
    (lambda obs: 1 / 0, "exception"),
    (lambda obs: (float("nan"), 0.0, 0.0), "invalid_action"),
    (lambda obs: (0.0, 0.0), "invalid_action"),
    (lambda obs: np.zeros((2, 3)), "invalid_action"),
    (lambda obs: "left", "invalid_action"),
])
def test_policy_faults_end_the_episode(harness, pet_in_reach, bad, kind):
    calls = []

    def policy(obs):
        calls.append(obs.t)
        return (0.0, 0.0, 0.0) if len(calls) < 5 else bad(obs)

    ep = _episode(harness, pet_in_reach, policy)
    assert ep.failure_kind == kind and ep.failure
    assert len(calls) == 5 and ep.trace is not None and ep.failure_time == pytest.approx(ep.trace.times[-1], abs=0.1)


def test_a_slow_policy_times_out(harness, pet_in_reach):
    import time

    ep = _episode(harness, pet_in_reach, lambda obs: time.sleep(0.3) or (0, 0, 0), timeout=0.05)
    assert ep.failure_kind == "timeout"


def test_variants_differ_and_the_scripted_robot_verifies_in_each(harness, pet_in_reach):
    vs = harness.sample_variants(pet_in_reach, 3, seed=0)
    assert vs[0] is pet_in_reach and len(vs) == 3
    spots = [tuple((v.parameters[n]["x"], v.parameters[n]["y"]) for n in ("pet1", "book1")) for v in vs]
    assert len(set(spots)) == 3
    for v in vs:
        run = harness.check_template(v)
        assert run.verdict is not None and run.verdict.status == "verified", run.error or run.verdict.reason
        assert run.collisions == []
        assert v.parameters["pet1"]["relation"] == "right_of"  # the relation is kept, the point moves


def test_extreme_variants_sit_elsewhere(harness, pet_in_reach):
    plain = harness.sample_variants(pet_in_reach, 2, seed=0)[1]
    far = harness.sample_variants(pet_in_reach, 2, seed=0, extremes=True)[1]
    assert plain.parameters != far.parameters


def test_variant_near_puts_the_objects_toward_the_room_edges_asked_for(harness, pet_in_reach):
    keys = harness.parameter_keys(pet_in_reach)
    assert keys == [("pet1", "x"), ("pet1", "y"), ("book1", "x"), ("book1", "y")]
    low, high = (harness.variant_near(pet_in_reach, {k: u for k in keys}, 0) for u in (0.0, 1.0))
    for name in ("pet1", "book1"):
        grounded, lo, hi = (v.parameters[name] for v in (pet_in_reach, low, high))
        assert lo["x"] <= grounded["x"] <= hi["x"] and lo["y"] <= grounded["y"] <= hi["y"]
        assert (lo["x"], lo["y"]) != (hi["x"], hi["y"])
        assert lo["relation"] == hi["relation"] == grounded["relation"]  # the relation holds, the point moves
    only_pet = harness.variant_near(pet_in_reach, {("pet1", "x"): 0.0}, 0)
    assert only_pet.parameters["pet1"]["x"] < pet_in_reach.parameters["pet1"]["x"]
    assert only_pet.parameters["book1"] == pet_in_reach.parameters["book1"]  # no target: where it stood
    with pytest.raises(KeyError, match="pet1.z"):
        harness.variant_near(pet_in_reach, {("pet1", "z"): 0.5}, 0)


def test_load_policy_specs(tmp_path):
    f = tmp_path / "mine.py"
    f.write_text("def policy(obs):\n    return (0.0, 0.0, 0.01, 0.0)\n\nclass Up:\n"
                 "    def __call__(self, obs):\n        return (0, 0, 0.02)\n")
    h = ManipulationHarness()
    assert h.load_policy(str(f))(None) == (0.0, 0.0, 0.01, 0.0)
    assert h.load_policy(f"{f}:Up")(None) == (0, 0, 0.02)
    with pytest.raises(ConfigError, match="built-in"):
        h.load_policy("nonsense")
    with pytest.raises(ConfigError, match="does not exist"):
        h.load_policy(str(tmp_path / "missing.py"))


def test_sac_without_a_model_names_the_extra_or_the_script():
    h = ManipulationHarness()
    with pytest.raises(ConfigError, match=r"rl extra|train_sac\.py"):
        h.load_policy("sac")


def test_failure_picture_is_a_gif(harness, pet_in_reach, tmp_path):
    ep = _episode(harness, pet_in_reach, _ram("pet1"))
    out = harness.failure_picture(pet_in_reach, ep, None, None, "ram", tmp_path / "f" / "failure.gif")
    assert out is not None and out.read_bytes()[:6] in (b"GIF89a", b"GIF87a")
