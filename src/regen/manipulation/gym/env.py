"""``regen/Manipulation-v0``: the verified manipulation scenarios of generated runs as a Gymnasium env.

An episode is one verified scenario of the given run folders, simulated in PyBullet as
``regen test`` simulates it (:class:`regen.manipulation.testing.loop.Session`: the context
objects are free bodies); unverified scenarios are skipped. One step is one policy period
(0.05 s, 20 Hz).

Action: ``Box(-1, 1, (4,))``: ``[dx, dy, dz]`` times ``MAX_STEP`` (0.03 m) is the hand set-point
displacement [m] (world frame) and ``a[3] > 0`` closes the hand (grasping a handle or the item
within 0.05 m), else opens it: the meaning of :class:`regen.manipulation.testing.types.Action`.
Values beyond [-1, 1] are clipped; anything but 4 finite numbers (a string, NaN, ``10**400``) is
a ValueError.

Observation: a float32 vector of :data:`OBS_SIZE` (every value clipped to ``[-LIMIT, LIMIT]``):

====== ================================================================================
0:9     joint positions (7 arm [rad], 2 fingers [m])
9:18    joint velocities [rad/s, m/s]
18:21   hand position [m]; 21:25 hand orientation (quaternion x, y, z, w)
25:28   hand set-point [m]; 28 gripper opening [m]; 29 hand closed (0/1); 30 holding (0/1)
31:34   task object position [m]; 34:37 its handle [m] (0 without); 37 its opening (0..1);
38      the opening the task drives to (0..1, 0 for other tasks)
39:42   task item position [m] (0 without); 42 item present (0/1)
43:45   where the item is put down [m]; 45 present (0/1)
46:94   6 context slots of 8: position [m] (3), size [m] (3), person or pet (0/1), present (0/1)
94      time left in the episode [s]
====== ================================================================================

Reward per step: the behavior's dense reward (:mod:`regen.manipulation.world.tasks`: RoboGen
style, e.g. ``-|hand - handle| - 2 |opening - goal|``) minus ``collision_penalty`` when the arm
touches a person or a pet (the episode terminates), plus ``success_bonus`` when a joint task's
goal opening is reached (the episode terminates). Truncated at the scenario's duration.

``info``: ``scenario``, ``t`` [s], ``collision`` (bool), ``collision_with``, ``is_success``; at the
episode's end also ``incidents`` (the harness's, in words) from the recorded trace.
"""

from __future__ import annotations

import weakref

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from regen.core.vectors import finite_vector
from regen.errors import ConfigError
from regen.harness.catalog import Entry, Picker, verified
from regen.manipulation.testing.loop import Session, prepare
from regen.manipulation.testing.types import MAX_STEP, POLICY_DT, Action, Observation

SLOTS = 6  # context objects observed (grounding places at most 6)
OBS_SIZE = 95
LIMIT = 100.0  # every observed value is clipped to +-LIMIT
COLLISION_PENALTY = 10.0
SUCCESS_BONUS = 5.0
DOMAIN = "manipulation"
ORDERS = ("random", "cycle")


def encode(obs: Observation, time_left: float) -> np.ndarray:
    """The observation as the flat vector documented in the module docstring."""
    r, task = obs.robot, obs.task
    v = np.zeros(OBS_SIZE, dtype=np.float64)
    v[0:9], v[9:18] = r.q, r.qd
    v[18:21], v[21:25], v[25:28] = r.ee_position, r.ee_orientation, r.ee_target
    v[28], v[29], v[30] = r.gripper_width, float(r.gripper_closed), float(r.holding is not None)
    target = obs.object(task.target)
    v[31:34] = target.position
    a = target.articulation
    if a is not None:
        v[34:37] = a.handle if a.handle is not None else (0.0, 0.0, 0.0)
        v[37] = a.fraction
    v[38] = task.goal_fraction or 0.0
    if task.item:
        v[39:42], v[42] = obs.object(task.item).position, 1.0
    if task.goal_xy is not None:
        v[43:45], v[45] = task.goal_xy, 1.0
    ctx = [o for o in obs.objects if o.role == "context"][:SLOTS]
    for k, o in enumerate(ctx):
        base = 46 + 8 * k
        v[base:base + 3], v[base + 3:base + 6] = o.position, o.size
        v[base + 6], v[base + 7] = float(o.living), 1.0
    v[94] = time_left
    return np.clip(v, -LIMIT, LIMIT).astype(np.float32)


def reward_inputs(obs: Observation) -> dict:
    """What the behaviors' reward functions read: hand, handle, opening, item, goal [m]."""
    task = obs.task
    ee = np.asarray(obs.robot.ee_position)
    a = obs.object(task.target).articulation
    out: dict = {"ee": ee, "handle": np.asarray(a.handle) if a is not None and a.handle else
                 np.asarray(obs.object(task.target).position), "fraction": a.fraction if a is not None else 0.0}
    moved = task.item or task.target
    out["item"] = np.asarray(obs.object(moved).position)
    interior = obs.object(task.target).interior
    if task.goal_xy is not None:
        out["goal"] = np.array([*task.goal_xy, out["item"][2]])
    elif interior is not None:
        out["goal"] = (np.asarray(interior[0]) + np.asarray(interior[1])) / 2
    else:
        out["goal"] = out["item"]
    return out


class ManipulationEnv(gym.Env):
    """Episodes are the verified manipulation scenarios of ``runs`` (run folder paths).

    ``order``: 'random' (seeded by ``reset(seed=...)``) or 'cycle'; ``reset(options={"scenario":
    NAME})`` picks one by folder name. Each env owns its own PyBullet client: several envs may
    run in one process.
    """

    metadata = {"render_modes": []}

    def __init__(self, runs, *, order: str = "random", collision_penalty: float = COLLISION_PENALTY,
                 success_bonus: float = SUCCESS_BONUS, render_mode: str | None = None):
        if render_mode is not None:
            raise ConfigError(f"regen/Manipulation-v0 renders nothing (render_mode={render_mode!r}); "
                              "the run folder's pictures show the scenarios")
        if order not in ORDERS:
            raise ConfigError(f"unknown order {order!r}; choose one of: {', '.join(ORDERS)}")
        self.render_mode = None
        self.entries, self.skipped = verified(runs, DOMAIN)
        self._picker = Picker(self.entries, order)
        if not self.entries:
            raise ConfigError(f"no verified manipulation scenario in {runs} ({len(self.skipped)} did not "
                              "verify): regen generate --domain manipulation makes them")
        self.order, self.collision_penalty, self.success_bonus = order, collision_penalty, success_bonus
        self.observation_space = spaces.Box(-LIMIT, LIMIT, shape=(OBS_SIZE,), dtype=np.float32)
        self.action_space = spaces.Box(-1.0, 1.0, shape=(4,), dtype=np.float32)
        self._slot: dict[str, Session | None] = {"session": None}
        self._finalizer = weakref.finalize(self, _close_slot, self._slot)  # no client outlives the env
        self._entry: Entry | None = None
        self._last: Observation | None = None

    @property
    def scenario_names(self) -> list[str]:
        return [e.name for e in self.entries]

    @property
    def policy_observation(self) -> Observation | None:
        """The latest observation as :mod:`regen.manipulation.testing.types` objects (so a
        built-in policy can drive the env); None before reset."""
        return self._last

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        _close_slot(self._slot)
        entry = self._picker.pick(options, self.np_random, seed)
        if entry.prepared is None:
            entry.prepared = prepare(entry.scenario)
        self._slot["session"], self._entry = Session(entry.prepared), entry
        self._steps, self._collision = 0, None
        self._n = int(round(entry.prepared.duration / POLICY_DT))
        self._last = self._slot["session"].observe()
        return self._encode(self._last), self._info(False)

    def step(self, action):
        session = self._slot["session"]
        if session is None:
            raise gym.error.ResetNeeded("call reset() before step() (the episode has ended)")
        a = np.clip(finite_vector(action, 4, "the action [dx, dy, dz, grip]"), -1.0, 1.0)
        seen = len(session.rec.tracks.get("robot", {}).get("contacts", []))
        session.apply(Action(*(a[:3] * MAX_STEP), gripper=1.0 if a[3] > 0 else 0.0))
        self._steps += 1
        obs = self._last = session.observe()
        recent = session.rec.tracks.get("robot", {}).get("contacts", [])[seen:]
        touched = set(session.rec.touched).union(*(set(c.split(",")) for c in recent if c))
        hit = next((n for n in session.prep.living if n in touched), None)
        reward = float(session.prep.behavior.reward(reward_inputs(obs)))
        success = self._success(obs)
        terminated = False
        if hit is not None:
            self._collision = self._collision or hit
            reward -= self.collision_penalty
            terminated = True
        if success:
            reward += self.success_bonus
            terminated = True
        truncated = not terminated and self._steps >= self._n
        info = self._info(success)
        if terminated or truncated:
            info["incidents"] = self._finish(session)
        return self._encode(obs), reward, terminated, truncated, info

    def _success(self, obs: Observation) -> bool:
        from regen.manipulation.simulation.sac import success

        a = obs.object(obs.task.target).articulation
        try:
            return a is not None and success(self._entry.prepared.behavior, a.fraction)
        except ValueError:  # not a joint behavior: the episode runs to its end
            return False

    def _finish(self, session: Session) -> list[str]:
        from regen.manipulation.testing.harness import ManipulationHarness

        self._slot["session"] = None
        try:
            trace = session.trace()
            return [i.message for i in ManipulationHarness().incidents(session.prep.scenario, trace)]
        finally:
            session.close()

    def _encode(self, obs: Observation) -> np.ndarray:
        return encode(obs, max(self._n - self._steps, 0) * obs.dt)

    def _info(self, success: bool) -> dict:
        return {"scenario": self._entry.name, "t": float(self._last.t), "collision": self._collision is not None,
                "collision_with": self._collision, "is_success": bool(success)}

    def close(self):
        _close_slot(self._slot)
        super().close()


def _close_slot(slot: dict) -> None:
    session = slot.get("session")
    slot["session"] = None
    if session is not None:
        session.close()


__all__ = ["COLLISION_PENALTY", "OBS_SIZE", "SUCCESS_BONUS", "ManipulationEnv", "encode", "reward_inputs"]
