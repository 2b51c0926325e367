"""The optional SAC controller: loading a saved policy (a missing or broken file is a clear
error naming it), running a policy in a scene until the task's joint goal, and the positive
load path when the rl extra (stable-baselines3) is installed."""

from __future__ import annotations

import zipfile

import numpy as np
import pytest

from regen.errors import ConfigError, DependencyNotInstalled
from regen.manipulation.simulation import sac
from regen.manipulation.world.tasks import get_behavior


def test_a_missing_policy_file_is_a_config_error_naming_it(tmp_path) -> None:
    missing = tmp_path / "sac_open_door_20000_s0.zip"
    with pytest.raises(ConfigError, match="no SAC policy file at .*sac_open_door_20000_s0.zip.*train_sac.py"):
        sac.load_sac(missing)
    with pytest.raises(ConfigError, match="no SAC policy file"):
        sac.load_sac(tmp_path)  # a folder is not a policy file either


def test_a_file_that_is_not_a_zip_is_a_config_error(tmp_path) -> None:
    bad = tmp_path / "policy.zip"
    bad.write_text("not a model", encoding="utf-8")
    with pytest.raises(ConfigError, match=r"policy.zip is not a saved SAC policy \(a stable-baselines3 .zip\)"):
        sac.load_sac(bad)


def test_a_zip_that_is_no_saved_model_is_a_config_error(tmp_path) -> None:
    other = tmp_path / "photos.zip"
    with zipfile.ZipFile(other, "w") as z:
        z.writestr("holiday.txt", "sun")
    with pytest.raises(ConfigError, match="not a saved stable-baselines3 model .*no 'data' entry"):
        sac.load_sac(other)


def test_a_saved_model_without_the_rl_extra_names_the_extra(tmp_path, monkeypatch) -> None:
    import builtins

    real_import = builtins.__import__

    def no_sb3(name, *args, **kwargs):
        if name.split(".")[0] == "stable_baselines3":
            raise ImportError(name)
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_sb3)
    looks_right = tmp_path / "sac.zip"
    with zipfile.ZipFile(looks_right, "w") as z:
        z.writestr("data", "{}")
    with pytest.raises(DependencyNotInstalled) as err:
        sac.load_sac(looks_right)
    assert err.value.extra == "rl" and "stable-baselines3" in str(err.value)


def test_success_is_the_task_joint_goal_and_joint_tasks_only() -> None:
    lamp = get_behavior("turn_on_lamp")  # joint_open at_least 0.6
    assert sac.success(lamp, 0.6) and not sac.success(lamp, 0.59)
    window = get_behavior("close_window")  # joint_closed at_most 0.08
    assert sac.success(window, 0.05) and not sac.success(window, 0.2)
    with pytest.raises(ValueError, match="joint behaviors only.*store_item"):
        sac.success(get_behavior("store_item"), 1.0)


class _Presser:
    """A stand-in for a trained policy (``predict`` as stable-baselines3 has it): over the
    switch, push down; else go above it."""

    def predict(self, obs, deterministic=True):
        ee, switch = obs[:3], obs[3:6]
        over = np.linalg.norm(ee[:2] - switch[:2]) < 0.01
        aim = switch + ([0, 0, -0.03] if over else [0, 0, 0.06])
        return np.clip((aim - ee) / sac.ACTION_SCALE, -1, 1), None


class _Idle:
    def predict(self, obs, deterministic=True):
        return np.zeros(3), None


@pytest.mark.parametrize("policy,done", [(_Presser(), True), (_Idle(), False)])
def test_run_policy_drives_the_scene_until_the_joint_goal(policy, done) -> None:
    pytest.importorskip("pybullet")
    from regen.manipulation.simulation.controller import Controller
    from regen.manipulation.simulation.layout import FurniturePlacement, SceneLayout
    from regen.manipulation.simulation.scene import Scene

    lamp = get_behavior("turn_on_lamp")
    layout = SceneLayout(furniture=[FurniturePlacement("lamp1", "lamp", *lamp.pose, lamp.start_fraction)])
    with Scene(layout) as scene:
        ctl = Controller(scene)
        assert sac.run_policy(policy, ctl, lamp, "lamp1", max_steps=60) is done
        assert (scene.joint_fraction("lamp1") >= 0.6) is done


def test_a_saved_model_loads_and_acts_in_the_workspace(tmp_path) -> None:
    sb3 = pytest.importorskip("stable_baselines3", reason="the rl extra installs stable-baselines3")
    pytest.importorskip("pybullet")
    env = sac.make_env("turn_on_lamp")
    try:
        model = sb3.SAC("MlpPolicy", env, policy_kwargs={"net_arch": [8]}, device="cpu", seed=0)
        obs, _ = env.reset(seed=0)
        path = tmp_path / "sac_turn_on_lamp.zip"
        model.save(str(path))
    finally:
        env.close()
    loaded = sac.load_sac(path)
    action, _ = loaded.predict(obs, deterministic=True)
    assert np.shape(action) == (3,) and np.all(np.abs(action) <= 1.0)
    expected, _ = model.predict(obs, deterministic=True)
    assert np.allclose(action, expected)
