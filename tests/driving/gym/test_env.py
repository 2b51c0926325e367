"""regen/Driving-v0: Gymnasium's env checker, collisions and rewards on the crossing child,
determinism, threads, registration (real Scenic Newtonian simulator)."""

from __future__ import annotations

import subprocess
import sys
import threading
import warnings

import gymnasium
import numpy as np
import pytest
from driving_chains import FEASIBLE, verified_run  # noqa: E402
from gymnasium.utils.env_checker import check_env

pytest.importorskip("scenic")

import regen.gym  # noqa: E402, F401 - registers regen/Driving-v0
from regen.driving.gym.observation import (  # noqa: E402
    OBS_NAMES,
    OBS_SIZE,
    decode_action,
    encode_action,
)
from regen.driving.testing.policies import MAX_BRAKE, load_policy  # noqa: E402
from regen.errors import ConfigError, RegenError  # noqa: E402
from regen.runfolder import RunFolder  # noqa: E402

pytestmark = pytest.mark.slow

CHILD = "01-child-crosses"  # stop_abruptly: a child runs across the road in front of the ego
CAR = "02-car-brakes"  # stop_abruptly: the car in front brakes hard


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    """A run folder with two verified scenarios."""
    yield from verified_run(tmp_path_factory, {CHILD: FEASIBLE["stop_abruptly"][0],
                                               CAR: FEASIBLE["stop_abruptly"][2]})


def _episode_threads() -> list[threading.Thread]:
    return [t for t in threading.enumerate() if t.name == "regen-gym-episode" and t.is_alive()]


def _drive(env, action_of, scenario=CHILD):
    """Run one episode; (summed reward, rewards, last step's terminated, truncated, info)."""
    obs, info = env.reset(seed=0, options={"scenario": scenario})
    assert info["scenario"] == scenario and obs.shape == (OBS_SIZE,)
    rewards = []
    while True:
        obs, reward, terminated, truncated, info = env.step(action_of(env))
        rewards.append(reward)
        if terminated or truncated:
            return sum(rewards), rewards, terminated, truncated, info


def test_check_env_passes_without_warnings(run_dir):
    env = gymnasium.make("regen/Driving-v0", runs=[run_dir], normalize_actions=True)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # any of check_env's warnings fails the test
        check_env(env.unwrapped)
    env.close()
    assert not _episode_threads()


def test_check_env_on_physical_actions_only_recommends_normalizing(run_dir):
    env = gymnasium.make("regen/Driving-v0", runs=[run_dir])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(env.unwrapped)
    env.close()
    messages = [str(w.message) for w in caught]
    assert messages and all("symmetric and normalized" in m for m in messages), messages


def test_constant_speed_hits_the_child_and_is_penalized(run_dir):
    env = gymnasium.make("regen/Driving-v0", runs=[run_dir])
    total, rewards, terminated, truncated, info = _drive(env, lambda e: np.array([0.0, 0.0], np.float32))
    env.close()
    assert terminated and not truncated
    assert info["collision"] and info["collision_with"] == "child1" and info["min_ttc"] == 0.0
    assert rewards[-1] < 0 and rewards[0] > 0  # progress, then the collision penalty
    verdict = info["verdict"]
    assert verdict["status"] == "failed" and verdict["cause"] == "collision" and "collision" in verdict["message"]


@pytest.mark.parametrize("driver", ["brake", "idm"])
def test_braking_and_idm_avoid_the_child(run_dir, driver):
    env = gymnasium.make("regen/Driving-v0", runs=[run_dir], oracle="safety")
    if driver == "brake":  # keep speed for 2 s, then full brake
        def action_of(e):
            t = e.unwrapped.policy_observation.t
            return np.array([0.0 if t < 2.0 else -MAX_BRAKE, 0.0], np.float32)
    else:  # the built-in IDM through the env's actions
        idm = load_policy("idm")

        def action_of(e):
            return encode_action(idm(e.unwrapped.policy_observation))
    total, rewards, terminated, truncated, info = _drive(env, action_of)
    steps = env.unwrapped.entries[0].prepared.steps
    env.close()
    assert truncated and not terminated and len(rewards) == steps
    assert not info["collision"] and info["min_ttc"] > 0 and total > 0
    assert info["verdict"]["status"] == "passed", info["verdict"]["message"]
    assert info["t"] == pytest.approx(steps * 0.1)


def test_reset_and_steps_are_deterministic_for_a_seed(run_dir):
    env = gymnasium.make("regen/Driving-v0", runs=[run_dir]).unwrapped

    def rollout(seed):
        obs, info = env.reset(seed=seed)
        out = [(obs, 0.0, info["scenario"])]
        for k in range(30):
            obs, reward, *_ = env.step(np.array([np.sin(k / 5.0), 0.05 * np.cos(k / 7.0)], np.float32))
            out.append((obs, reward, info["scenario"]))
        return out

    first, again = rollout(7), rollout(7)
    for (o1, r1, s1), (o2, r2, s2) in zip(first, again, strict=True):
        assert s1 == s2 and r1 == r2 and np.array_equal(o1, o2)
    picks = {env.reset(seed=s)[1]["scenario"] for s in range(12)}
    assert picks == {CHILD, CAR}  # the seed picks the scenario
    env.close()


def test_cycle_order_visits_every_scenario(run_dir):
    env = gymnasium.make("regen/Driving-v0", runs=[run_dir], order="cycle")
    names = [env.reset(seed=0 if k == 0 else None)[1]["scenario"] for k in range(4)]
    env.close()
    assert names == [CHILD, CAR, CHILD, CAR]


def test_close_and_reset_mid_episode_leave_no_thread(run_dir):
    env = gymnasium.make("regen/Driving-v0", runs=[run_dir])
    env.reset(seed=1)
    for _ in range(5):
        env.step(env.action_space.sample())
    assert len(_episode_threads()) == 1
    env.reset(seed=2)  # abandons the running episode
    env.step(env.action_space.sample())
    assert len(_episode_threads()) == 1
    env.close()
    assert not _episode_threads()
    env.close()  # twice is fine
    with pytest.raises(gymnasium.error.ResetNeeded):
        env.unwrapped.step(np.zeros(2, np.float32))


def test_a_second_env_in_the_process_waits_for_the_first(run_dir):
    first = gymnasium.make("regen/Driving-v0", runs=[run_dir]).unwrapped
    second = gymnasium.make("regen/Driving-v0", runs=[run_dir]).unwrapped
    first.reset(seed=0)
    with pytest.raises(RegenError, match="one simulation per process"):
        second.reset(seed=0)
    first.close()
    second.reset(seed=0)
    second.step(np.zeros(2, np.float32))
    second.close()
    assert not _episode_threads()


def test_make_by_module_id_without_importing_regen_gym(run_dir):
    code = ("import sys, gymnasium\n"
            f"env = gymnasium.make('regen.gym:regen/Driving-v0', runs=[{str(run_dir)!r}])\n"
            "print(env.unwrapped.scenario_names, env.observation_space.shape)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert f"['{CHILD}', '{CAR}'] ({OBS_SIZE},)" in out.stdout


def test_runs_without_a_verified_scenario_are_refused(tmp_path):
    (tmp_path / RunFolder.SCENARIOS).mkdir()
    with pytest.raises(ConfigError, match="no verified driving scenario"):
        gymnasium.make("regen/Driving-v0", runs=[tmp_path])
    with pytest.raises(ConfigError, match="not a run folder"):
        gymnasium.make("regen/Driving-v0", runs=[tmp_path / "missing"])


def test_action_and_observation_layout():
    assert len(OBS_NAMES) == OBS_SIZE and OBS_NAMES[0] == "ego.x"
    assert decode_action([-1.0, 1.0], normalized=True).acceleration == -MAX_BRAKE
    assert decode_action([0.0, 0.0], normalized=True).acceleration == 0.0
    assert decode_action([99.0, -9.0]).curvature == -0.2
    with pytest.raises(ValueError, match="finite"):
        decode_action([float("nan"), 0.0])
