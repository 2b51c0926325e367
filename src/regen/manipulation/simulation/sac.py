"""Optional learned controller: SAC (stable-baselines3) on a behavior's reward, trained once.

The environment wraps the behavior's scene (robot, furniture, table) and its dense reward
(:mod:`regen.manipulation.world.tasks`). Actions are end-effector displacements (top-down hand);
observations are the hand position, the handle position and the joint fraction, so a policy
trained in the bare scene runs unchanged in every generated context. The trained policy is
cached under the user cache dir (``policies/``) and reused; :func:`load_sac` loads a saved one
and says what is wrong with a missing or broken file.

Needs the ``rl`` extra (stable-baselines3, gymnasium, torch==2.13.0); without it,
:class:`regen.errors.DependencyNotInstalled` names the extra.
"""

from __future__ import annotations

import logging
import time
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

from regen.errors import ConfigError, DependencyNotInstalled
from regen.manipulation.simulation.arm import CONTROL_EVERY
from regen.manipulation.simulation.controller import Controller
from regen.manipulation.simulation.layout import FurniturePlacement, SceneLayout
from regen.manipulation.simulation.scene import Scene
from regen.manipulation.world.tasks import BehaviorDef, get_behavior
from regen.paths import cache_dir

log = logging.getLogger(__name__)

ACTION_SCALE = 0.02  # [m] hand displacement per action at |a| = 1
TICKS_PER_ACTION = 3  # control updates per action (12 physics steps, 20 Hz)
EPISODE_STEPS = 60  # actions per episode (3 s simulated)
SUCCESS_BONUS = 5.0
WORKSPACE = (np.array([0.2, -0.4, 0.03]), np.array([0.75, 0.4, 0.6]))  # hand set-point box [m]


def _require() -> tuple[Any, Any]:
    try:
        import gymnasium
        import stable_baselines3
    except ImportError:
        raise DependencyNotInstalled("stable-baselines3", "rl", "the SAC controller") from None
    return gymnasium, stable_baselines3


def observe(ctl: Controller, furniture: str) -> np.ndarray:
    s = ctl.scene
    return np.concatenate([np.asarray(s.ee_position()), np.asarray(s.handle_position(furniture)),
                           [s.joint_fraction(furniture)]]).astype(np.float32)


def act(ctl: Controller, action: np.ndarray) -> None:
    """Move the hand set-point by ``action * ACTION_SCALE`` [m] and run one action period."""
    a = np.clip(np.asarray(action, dtype=float), -1.0, 1.0)
    ctl.approach = "top"
    ctl.target = np.clip(ctl.target + a * ACTION_SCALE, *WORKSPACE)
    for _ in range(TICKS_PER_ACTION):
        ctl.tick(CONTROL_EVERY)


def success(behavior: BehaviorDef, fraction: float) -> bool:
    """The behavior's joint goal (the same threshold as its success predicate)."""
    for c in behavior.success:
        if c.name == "joint_open":
            return fraction >= float(c.params.get("at_least", 0.5))
        if c.name == "joint_closed":
            return fraction <= float(c.params.get("at_most", 0.1))
    raise ValueError(f"SAC here supports joint behaviors only, not {behavior.id!r}")


def make_env(behavior_id: str = "turn_on_lamp", seed: int = 0):
    """A gymnasium env for one joint behavior (press a switch, push a drawer ...)."""
    gym, _ = _require()
    from gymnasium import spaces

    behavior = get_behavior(behavior_id)

    class BehaviorEnv(gym.Env):
        metadata = {"render_modes": []}

        def __init__(self) -> None:
            self.observation_space = spaces.Box(-2.0, 2.0, shape=(7,), dtype=np.float32)
            self.action_space = spaces.Box(-1.0, 1.0, shape=(3,), dtype=np.float32)
            fx, fy = behavior.pose
            layout = SceneLayout(furniture=[FurniturePlacement("target", behavior.furniture, fx, fy,
                                                               behavior.start_fraction)])
            self.scene = Scene(layout)
            self.state_id = self.scene.call("saveState")
            self.ctl: Controller | None = None
            self.t = 0

        def reset(self, *, seed: int | None = None, options: dict | None = None):
            super().reset(seed=seed)
            self.scene.call("restoreState", self.state_id)
            self.ctl = Controller(self.scene)
            self.ctl.approach = "top"
            self.ctl.set_fingers(0.0)
            start = np.asarray(self.scene.ee_position()) + self.np_random.uniform(-0.05, 0.05, 3)
            self.ctl.target = np.clip(start, *WORKSPACE)
            self.ctl.tick(CONTROL_EVERY * 6)
            self.t = 0
            return observe(self.ctl, "target"), {}

        def step(self, action):
            assert self.ctl is not None
            act(self.ctl, action)
            self.t += 1
            obs = observe(self.ctl, "target")
            frac = float(obs[6])
            done = success(behavior, frac)
            r = behavior.reward({"ee": obs[:3], "handle": obs[3:6], "fraction": frac})
            if done:
                r += SUCCESS_BONUS
            return obs, float(r), done, self.t >= EPISODE_STEPS, {"is_success": done}

        def close(self) -> None:
            self.scene.close()

    env = BehaviorEnv()
    env.reset(seed=seed)
    return env


def policy_path(behavior_id: str, steps: int, seed: int) -> Path:
    return cache_dir("policies") / f"sac_{behavior_id}_{steps}_s{seed}.zip"


TRAIN_HINT = "train one with `python scripts/train_sac.py --behavior BEHAVIOR`"


def load_sac(path: str | Path) -> Any:
    """The SAC model saved at ``path`` (a stable-baselines3 ``.zip``), on the CPU.

    :class:`ConfigError` naming the path when there is no file there, or it is not a saved
    stable-baselines3 model, or it does not load; :class:`DependencyNotInstalled` (the ``rl``
    extra) when the file looks right but stable-baselines3 is missing."""
    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"no SAC policy file at {path}; {TRAIN_HINT}")
    if not zipfile.is_zipfile(path):
        raise ConfigError(f"{path} is not a saved SAC policy (a stable-baselines3 .zip); {TRAIN_HINT}")
    with zipfile.ZipFile(path) as z:
        if "data" not in z.namelist():
            raise ConfigError(f"{path} is a zip file but not a saved stable-baselines3 model (it has "
                              f"no 'data' entry); {TRAIN_HINT}")
    _, sb3 = _require()
    try:
        return sb3.SAC.load(str(path), device="cpu")
    except Exception as exc:  # a truncated or foreign model: say which file
        raise ConfigError(f"could not load the SAC policy {path}: {exc}") from exc


def train_sac(behavior_id: str = "turn_on_lamp", *, steps: int = 20000, seed: int = 0,
              retrain: bool = False) -> tuple[Any, dict[str, float]]:
    """Train (or load the cached) SAC policy for a joint behavior; returns (model, info) with
    the training wall time [s] (0 when loaded from the cache)."""
    _, sb3 = _require()
    path = policy_path(behavior_id, steps, seed)
    if path.exists() and not retrain:
        return load_sac(path), {"train_seconds": 0.0, "cached": 1.0}
    import torch

    torch.set_num_threads(1)
    env = make_env(behavior_id, seed)
    model = sb3.SAC("MlpPolicy", env, learning_rate=1e-3, buffer_size=50_000, learning_starts=500,
                    batch_size=128, gamma=0.95, policy_kwargs={"net_arch": [64, 64]}, seed=seed,
                    device="cpu", verbose=0)
    t0 = time.perf_counter()
    model.learn(total_timesteps=steps)
    wall = time.perf_counter() - t0
    model.save(str(path))
    env.close()
    log.info("trained SAC for %s in %.0f s -> %s", behavior_id, wall, path)
    return model, {"train_seconds": wall, "cached": 0.0}


def run_policy(policy: Any, ctl: Controller, behavior: BehaviorDef, furniture: str,
               max_steps: int = EPISODE_STEPS * 2) -> bool:
    """Run a trained policy in a generated scene until the behavior's goal or ``max_steps``."""
    ctl.approach = "top"
    ctl.set_fingers(0.0)
    for _ in range(max_steps):
        obs = observe(ctl, furniture)
        if success(behavior, float(obs[6])):
            ctl.wait(0.3)
            return True
        action, _ = policy.predict(obs, deterministic=True)
        act(ctl, action)
    return success(behavior, ctl.scene.joint_fraction(furniture))


__all__ = ["ACTION_SCALE", "EPISODE_STEPS", "TRAIN_HINT", "WORKSPACE", "act", "load_sac", "make_env", "observe",
           "policy_path", "run_policy", "success", "train_sac"]
