"""regen/Manipulation-v0: Gymnasium's env checker, the scripted policy reaching the goal,
a collision terminating the episode, registration of every domain's envs (real PyBullet)."""

from __future__ import annotations

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

pytest.importorskip("pybullet")

import regen.gym  # noqa: E402, F401 - registers the envs
from regen.manipulation.gym.env import COLLISION_PENALTY, OBS_SIZE  # noqa: E402
from regen.manipulation.testing.policies import Scripted  # noqa: E402
from regen.manipulation.testing.types import MAX_STEP  # noqa: E402


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    """A run folder with one verified door scenario (a pet within the arm's reach)."""
    from manipulation_chains import door_scenario

    from regen import domains
    from regen.pipeline import simulate_stage
    from regen.runfolder import RunFolder, ScenarioFolder

    run = tmp_path_factory.mktemp("run")
    sc = door_scenario({"pet1": ("right_of", "robot")}, ["pet"])
    folder = ScenarioFolder(run / RunFolder.SCENARIOS / "01-pet")
    folder.path.mkdir(parents=True)
    folder.write_scenario(sc, domains.make("manipulation").config(sc))
    out = simulate_stage("manipulation", str(folder.path), False)
    assert out["verdict"]["feasible"], out["verdict"]["reason"]
    return run


def _vector(action) -> np.ndarray:
    return np.clip(np.array([action.dx / MAX_STEP, action.dy / MAX_STEP, action.dz / MAX_STEP,
                             1.0 if action.gripper > 0.5 else -1.0], dtype=np.float32), -1, 1)


def test_every_domains_env_is_registered():
    assert {"regen/Driving-v0", "regen/Manipulation-v0"} <= set(gymnasium.registry)
    from regen.gym import DrivingEnv, ManipulationEnv

    assert DrivingEnv.__name__ == "DrivingEnv" and ManipulationEnv.__name__ == "ManipulationEnv"


def test_check_env_passes(run_dir):
    env = gymnasium.make("regen/Manipulation-v0", runs=[run_dir])
    check_env(env.unwrapped)
    obs, info = env.reset(seed=1)
    assert obs.shape == (OBS_SIZE,) and info["scenario"] == "01-pet"
    env.close()


def test_scripted_actions_open_the_door_and_end_the_episode(run_dir):
    env = gymnasium.make("regen/Manipulation-v0", runs=[run_dir]).unwrapped
    env.reset(seed=0)
    policy = Scripted()
    policy.reset()
    rewards = []
    for _ in range(240):
        _, r, terminated, truncated, info = env.step(_vector(policy(env.policy_observation)))
        rewards.append(r)
        if terminated or truncated:
            break
    assert terminated and info["is_success"] and not info["collision"]
    assert info["incidents"] == []
    assert rewards[-1] > rewards[0]  # the dense reward grows as the door opens
    env.close()


def test_ramming_the_pet_terminates_with_the_penalty(run_dir):
    env = gymnasium.make("regen/Manipulation-v0", runs=[run_dir]).unwrapped
    env.reset(seed=0)
    for _ in range(240):
        obs = env.policy_observation
        d = np.asarray(obs.object("pet1").position) - np.asarray(obs.robot.ee_position)
        _, r, terminated, truncated, info = env.step(np.array([*(d / np.linalg.norm(d)), -1.0], dtype=np.float32))
        if terminated or truncated:
            break
    assert terminated and info["collision_with"] == "pet1" and r < -COLLISION_PENALTY / 2
    assert any("pet1" in m for m in info["incidents"])
    with pytest.raises(gymnasium.error.ResetNeeded):
        env.step(np.zeros(4, dtype=np.float32))
    env.close()


@pytest.mark.parametrize("action", [[10**400, 0, 0, 0], "open", None, [0.0, "x", 0.0, 0.0],
                                    [float("nan"), 0, 0, 0], [0.0, 0.0, 0.0], object()],
                         ids=["huge", "string", "none", "string-entry", "nan", "short", "object"])
def test_bad_actions_are_value_errors_and_the_episode_goes_on(run_dir, action):
    env = gymnasium.make("regen/Manipulation-v0", runs=[run_dir]).unwrapped
    env.reset(seed=0)
    with pytest.raises(ValueError, match="4 finite numbers"):
        env.step(action)
    obs, *_ = env.step(np.zeros(4, dtype=np.float32))  # nothing of the bad action got in
    assert np.all(np.isfinite(obs))
    env.close()
