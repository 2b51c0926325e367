"""The built-in manipulation policies and :func:`load_policy`.

Built in (:data:`BUILTIN`):

- ``scripted``: the scripted controller (:mod:`regen.manipulation.simulation.scripted`) rewritten
  as a
  closed-loop policy over the observation alone: the same primitive sequence (approach the
  handle, grasp, drag it along its joint, let go, back off; press a switch; pick and place),
  the same speeds and tolerances. It sees nothing the observation does not hold.
- ``random``: uniform set-point displacements within the limits and a random gripper command
  each step (seeded, the same every episode): the baseline that should fail.
- ``sac``: the trained SAC policy of :mod:`regen.manipulation.simulation.sac` for the scenario's
  behavior
  (joint behaviors; needs the ``rl`` extra and a model trained by ``scripts/train_sac.py``).

:func:`load_policy` resolves a SPEC: a built-in name, ``module:callable`` or
``path/to/file.py[:callable]`` (imported by file path, so a file outside the repository works;
without ``:callable`` the file's ``policy``).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from regen.errors import ConfigError, install_hint
from regen.manipulation.testing.types import MAX_STEP, POLICY_DT, Action, Observation

MOVE_SPEED = 0.35  # [m/s] as regen.manipulation.simulation.arm.MOVE_SPEED
LEAD = 0.03  # [m] how far ahead of the handle the drag aims (as the controller)
JOINT_RATE = 0.5  # [rad/s] slowest drag along an arc (as the controller)


def _rotate(v: np.ndarray, axis: np.ndarray, angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return v * c + np.cross(axis, v) * s + axis * np.dot(axis, v) * (1 - c)


class _Phase:
    """One primitive; ``step`` returns the action, or None when the phase is over."""

    timeout = 4.0  # [s]

    def start(self, obs: Observation) -> None:
        pass

    def step(self, obs: Observation, grip: float) -> Action | None:
        raise NotImplementedError


class _Move(_Phase):
    """Move the set-point in a straight line to a point fixed when the phase starts."""

    def __init__(self, where: Callable[[Observation], np.ndarray], *, speed: float = MOVE_SPEED,
                 tol: float = 0.015, timeout: float = 4.0):
        self.where, self.speed, self.tol, self.timeout = where, speed, tol, timeout

    def start(self, obs: Observation) -> None:
        self.goal = np.asarray(self.where(obs), dtype=float)

    def step(self, obs: Observation, grip: float) -> Action | None:
        sp = np.asarray(obs.robot.ee_target)
        d = self.goal - sp
        dist = float(np.linalg.norm(d))
        if dist < 1e-4 and np.linalg.norm(np.asarray(obs.robot.ee_position) - self.goal) < self.tol:
            return None
        d = d if dist <= self.speed * POLICY_DT else d / dist * self.speed * POLICY_DT
        return Action(*d, gripper=grip)


class _Grip(_Phase):
    def __init__(self, close: bool, hold: float = POLICY_DT):
        self.close, self.hold = close, hold

    def start(self, obs: Observation) -> None:
        self.left = max(1, round(self.hold / POLICY_DT))

    def step(self, obs: Observation, grip: float) -> Action | None:
        if self.left <= 0:
            return None
        self.left -= 1
        return Action(gripper=1.0 if self.close else 0.0)


class _Wait(_Grip):
    def __init__(self, seconds: float):
        super().__init__(False, seconds)

    def step(self, obs: Observation, grip: float) -> Action | None:
        if self.left <= 0:
            return None
        self.left -= 1
        return Action(gripper=grip)


class _Follow(_Phase):
    """Drag the held handle along its joint until the goal fraction (as Controller.follow_joint)."""

    timeout = 6.0

    def __init__(self, target: str, fraction: float, stall: float = 1.5):
        self.target, self.fraction, self.stall = target, fraction, stall

    def start(self, obs: Observation) -> None:
        self.best, self.since = math.inf, 0.0

    def step(self, obs: Observation, grip: float) -> Action | None:
        a = obs.object(self.target).articulation
        if a is None or obs.robot.holding != self.target:
            return None
        goal = a.closed + self.fraction * (a.opened - a.closed)
        err = goal - a.position
        revolute = a.joint_type == "revolute"
        if abs(err) < (0.02 if revolute else 0.004):
            return None
        if abs(err) < self.best - 1e-3:
            self.best, self.since = abs(err), 0.0
        else:
            self.since += POLICY_DT
            if self.since > self.stall:
                return None
        ee, origin, axis = (np.asarray(v, dtype=float) for v in (obs.robot.ee_position, a.origin, a.axis))
        if revolute:
            arm = ee - origin
            radius = max(float(np.linalg.norm(arm - axis * np.dot(arm, axis))), 0.02)
            dq = math.copysign(min(abs(err) + 0.03, max(LEAD / radius, JOINT_RATE * POLICY_DT)), err)
            aim = origin + _rotate(arm, axis, dq)
        else:
            aim = ee + axis * math.copysign(min(abs(err) + 0.01, LEAD), err)
        return Action(*(aim - np.asarray(obs.robot.ee_target)), gripper=grip)


def _back(obs: Observation, dist: float) -> np.ndarray:
    return np.array([-dist, 0, 0]) if obs.task.approach == "front" else np.array([0, 0, dist])


def _handle(obs: Observation) -> np.ndarray:
    a = obs.object(obs.task.target).articulation
    assert a is not None and a.handle is not None
    return np.asarray(a.handle)


def _grip_point(obs: Observation, name: str) -> np.ndarray:
    o = obs.object(name)
    c, size = np.asarray(o.position), np.asarray(o.size)
    return np.array([c[0], c[1], c[2] + size[2] / 2 - min(0.02, size[2] / 2)])


def _ee(obs: Observation) -> np.ndarray:
    return np.asarray(obs.robot.ee_position)


def _plan(obs: Observation) -> list[_Phase]:
    """The scripted controller's sequence for the task (regen.manipulation.simulation.scripted)."""
    from regen.manipulation.world.tasks import get_behavior

    task = obs.task
    behavior = get_behavior(task.behavior)
    if behavior.script == "articulate":
        return [_Move(lambda o: _handle(o) + _back(o, 0.1)), _Move(_handle, tol=0.02),
                _Grip(True, 0.1), _Follow(task.target, float(task.goal_fraction or 0.0)),
                _Grip(False), _Move(lambda o: _ee(o) + _back(o, 0.08), timeout=2.0), _Wait(0.3)]
    if behavior.script == "press":
        return [_Grip(True), _Move(lambda o: _handle(o) + [0, 0, 0.1]),
                _Move(lambda o: _handle(o) - [0, 0, 0.02], speed=0.1, timeout=2.0), _Wait(0.2),
                _Move(lambda o: _ee(o) + [0, 0, 0.12], timeout=2.0), _Wait(0.3)]
    if behavior.script == "carry":
        gx, gy = task.goal_xy or (0.0, 0.0)
        return [_Move(lambda o: _handle(o) + [0, 0, 0.1]), _Move(_handle, tol=0.02), _Grip(True),
                _Move(lambda o: _ee(o) + [0, 0, 0.12], speed=0.2),
                _Move(lambda o: np.array([gx, gy, _ee(o)[2]]), speed=0.2),
                _Move(lambda o: np.array([gx, gy, _ee(o)[2] - 0.115]), speed=0.1, tol=0.02),
                _Grip(False), _Move(lambda o: _ee(o) + [0, 0, 0.12], timeout=1.5), _Wait(0.4)]
    item = task.item
    assert item is not None
    if task.approach == "front":  # a side grasp inside the fridge
        c = lambda o: np.asarray(o.object(item).position)  # noqa: E731
        return [_Move(lambda o: c(o) + [-0.15, 0, 0.01]), _Move(lambda o: c(o) + [0, 0, 0.01], tol=0.02),
                _Grip(True), _Move(lambda o: _ee(o) + [0, 0, 0.04], tol=0.02),
                _Move(lambda o: np.array([0.38, _ee(o)[1], _ee(o)[2]]), tol=0.03), _Wait(0.3)]

    def put(o: Observation) -> np.ndarray:
        it = o.object(item)
        above_bottom = _ee(o)[2] - (it.position[2] - it.size[2] / 2)
        interior = o.object(task.target).interior
        if interior is not None and task.goal_xy is None:  # into the furniture
            lo, hi = interior
            return np.array([lo[0] + max(it.size[0] / 2 + 0.03, 0.08), (lo[1] + hi[1]) / 2,
                             lo[2] + above_bottom + 0.05])
        gx, gy = task.goal_xy or (0.4, 0.0)
        return np.array([gx, gy, above_bottom + 0.02])

    return [_Move(lambda o: [*_grip_point(o, item)[:2], max(0.45, _grip_point(o, item)[2] + 0.12)]),
            _Move(lambda o: _grip_point(o, item) + [0, 0, 0.12]), _Move(lambda o: _grip_point(o, item), tol=0.02),
            _Grip(True), _Move(lambda o: _ee(o) + [0, 0, 0.2], tol=0.03),
            _Move(lambda o: _ee(o) + [0, 0, 0.15], tol=0.03),
            _Move(lambda o: [*put(o)[:2], max(0.55, put(o)[2] + 0.15)], tol=0.03),
            _Move(put, speed=0.15, tol=0.02), _Grip(False),
            _Move(lambda o: _ee(o) + [0, 0, 0.12], timeout=1.5), _Wait(0.4)]


class Scripted:
    """The scripted controller's primitives as a closed-loop policy (``--policy scripted``)."""

    def reset(self) -> None:
        self.phases: list[_Phase] | None = None
        self.i, self.elapsed, self.grip = 0, 0.0, 0.0

    def __call__(self, obs: Observation) -> Action:
        if getattr(self, "phases", None) is None:
            self.reset()
            self.phases = _plan(obs)
            self.phases[0].start(obs)
        while self.i < len(self.phases):
            phase = self.phases[self.i]
            act = phase.step(obs, self.grip) if self.elapsed <= phase.timeout else None
            if act is not None:
                self.elapsed += POLICY_DT
                self.grip = act.gripper
                return act
            self.i, self.elapsed = self.i + 1, 0.0
            if self.i < len(self.phases):
                self.phases[self.i].start(obs)
        return Action(gripper=self.grip, done=True)


class RandomPolicy:
    """Uniform displacements in [-MAX_STEP, MAX_STEP] [m] per axis and a uniform gripper command
    in [0, 1]; seeded with ``seed`` at every reset (``--policy random``)."""

    def __init__(self, seed: int = 0):
        self.seed = seed
        self.reset()

    def reset(self) -> None:
        self.rng = np.random.default_rng(self.seed)

    def __call__(self, obs: Observation) -> Action:
        d = self.rng.uniform(-MAX_STEP, MAX_STEP, 3)
        return Action(*d, gripper=float(self.rng.uniform()))


class SACPolicy:
    """The trained SAC model of the scenario's behavior (:mod:`regen.manipulation.simulation.sac`):
    its observation (hand, handle, opening) and its action (hand displacement of up to
    ``sac.ACTION_SCALE`` [m] per axis, hand closed) in this loop's terms."""

    def __init__(self) -> None:
        try:
            import stable_baselines3  # noqa: F401
        except ImportError:
            raise ConfigError(f"--policy sac needs the rl extra (stable-baselines3): {install_hint('rl')}") from None
        if not self._models():
            raise ConfigError("--policy sac found no trained SAC model; train one with "
                              "`python scripts/train_sac.py --behavior BEHAVIOR` (a joint behavior, "
                              "e.g. open_door or turn_on_lamp)")
        self.loaded: dict[str, object] = {}

    @staticmethod
    def _models(behavior: str = "*") -> list:
        from regen.paths import cache_dir

        return sorted(cache_dir("policies").glob(f"sac_{behavior}_*.zip"))

    def __call__(self, obs: Observation) -> Action:
        from regen.manipulation.simulation.sac import ACTION_SCALE, load_sac

        b = obs.task.behavior
        if b not in self.loaded:
            found = self._models(b)
            if not found:
                raise ConfigError(f"no trained SAC model for {b}; train one with "
                                  f"`python scripts/train_sac.py --behavior {b}`")
            self.loaded[b] = load_sac(found[-1])
        a = obs.object(obs.task.target).articulation
        if a is None or a.handle is None:
            raise ConfigError(f"the SAC policy drives joint behaviors only, not {b}")
        x = np.concatenate([obs.robot.ee_position, a.handle, [a.fraction]]).astype(np.float32)
        act, _ = self.loaded[b].predict(x, deterministic=True)
        return Action(*(np.clip(act, -1, 1) * ACTION_SCALE), gripper=1.0)


BUILTIN: dict[str, Callable[[], Callable]] = {"scripted": Scripted, "random": RandomPolicy, "sac": SACPolicy}
DESCRIPTIONS = {
    "scripted": "the scripted controller's motion primitives, closed-loop over the observation",
    "random": "uniform random hand displacements and gripper commands (seeded)",
    "sac": "the trained SAC policy of the behavior (rl extra and scripts/train_sac.py)",
}


def load_policy(spec: str) -> Callable:
    """The policy a SPEC names: a built-in name (scripted, random, sac), ``module:callable`` or
    ``path/to/file.py[:callable]`` (default callable: ``policy``). A class is instantiated;
    ConfigError if the SPEC names nothing callable."""
    from regen.harness.loading import load_callable

    return load_callable(spec, BUILTIN)


__all__ = ["BUILTIN", "DESCRIPTIONS", "RandomPolicy", "SACPolicy", "Scripted", "load_policy"]
