"""One verified manipulation scenario as a robot-learning episode: per dataset frame the robot's
joint positions, the action, the scene's task-relevant poses, the reward, both cameras' pictures.

Frames are the trace's samples (``RECORD_HZ`` = 24 Hz) subsampled to :data:`FPS` (every second
sample); a frame's ``timestamp`` is ``frame_index / FPS`` [s] from the episode's start.

- ``observation.state``: the Panda's 7 arm joint angles [rad] and 2 finger positions [m].
- ``action``: the joint targets the controller commanded [rad, m], the last ones of the period
  after the frame (the trace's ``cmd_q*``: the rollout records them). A trace recorded before
  those were kept has none: then the action is the next frame's joint positions, for every
  episode of the dataset alike (:data:`ACTION_NEXT_STATE`).
- ``observation.environment_state``: :data:`ENV_NAMES`: the hand, the target furniture, its
  handle and opening, and the moved item [m] (zeros when the behavior moves none).
- ``next.reward``: the behavior's own dense reward (:mod:`regen.manipulation.world.tasks`)
  after the frame's action, for behaviors whose reward reads only what the trace records (the
  joint behaviors: reach the handle, move the joint); None for the others (their goal is where
  the scripted controller puts the item, which the trace does not record).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from regen.core.scenario import Scenario
from regen.core.trace import ActorTrack, Trace
from regen.errors import ConfigError
from regen.manipulation.simulation.record import RECORD_HZ
from regen.manipulation.simulation.run import layout_from_scenario

FPS = 12  # dataset frames per second: every RECORD_HZ // FPS-th trace sample
STATE_NAMES = [*(f"panda_joint{k}" for k in range(1, 8)), "panda_finger_joint1", "panda_finger_joint2"]
ENV_NAMES = ["ee_x", "ee_y", "ee_z", "target_x", "target_y", "target_z", "handle_x", "handle_y",
             "handle_z", "target_joint_fraction", "item_x", "item_y", "item_z"]
ACTION_COMMAND = "commanded joint targets (cmd_q0..cmd_q8 of the trace) at the end of the frame's period"
ACTION_NEXT_STATE = "the next frame's joint positions (the traces hold no commanded targets)"
REWARD_SCRIPTS = ("articulate", "press")  # behaviors whose reward the trace fully determines
CONTEXT_SEP = " \u2014 context: "


@dataclass
class Episode:
    """Columns of one episode, one row per dataset frame."""

    name: str  # where it came from: run folder / scenario folder
    status: str  # the verdict's status
    task: str
    samples: list[int]  # the trace sample of each frame
    state: np.ndarray  # (n, 9) float32
    command: np.ndarray | None  # (n, 9) float32, None when the trace lacks cmd_q*
    environment: np.ndarray  # (n, 13) float32
    reward: np.ndarray | None  # (n,) float32

    @property
    def length(self) -> int:
        return len(self.samples)

    def action(self, source: str) -> np.ndarray:
        """The action column: commanded targets, or the next frame's joint positions."""
        nxt = np.minimum(np.arange(1, self.length + 1), self.length - 1)  # the last frame: its own
        if source == ACTION_COMMAND:
            assert self.command is not None
            return self.command[nxt]  # the targets in force when the next frame is sampled
        return self.state[nxt]


def task_text(scenario: Scenario) -> str:
    """The behavior with its context: ``<behavior> — context: <cause>; <cause>``."""
    behavior = scenario.behavior.text.strip()
    causes = [c.strip() for c in scenario.causal_graph[:-1] if c.strip() and c.strip() != behavior]
    return behavior + (CONTEXT_SEP + "; ".join(causes) if causes else "")


def frame_samples(trace: Trace) -> list[int]:
    """The trace samples that become dataset frames (every ``RECORD_HZ // FPS``-th)."""
    rate = 1.0 / trace.dt
    step = round(rate / FPS)
    if step < 1 or abs(rate - step * FPS) > 1e-6 * rate:
        raise ConfigError(f"the trace is sampled at {rate:g} Hz, not a multiple of the dataset's "
                          f"{FPS} fps (manipulation traces are recorded at {RECORD_HZ} Hz)")
    return list(range(0, trace.steps, step))


def _cols(track: ActorTrack, keys: list[str], idx: list[int]) -> np.ndarray | None:
    if not all(k in track.states for k in keys):
        return None
    return np.array([[float(track.states[k][i]) for k in keys] for i in idx], dtype=np.float32)


def _centre(track: ActorTrack, idx: list[int]) -> np.ndarray:
    return np.array([[track.x[i], track.y[i], track.z[i] if track.z else 0.0] for i in idx], dtype=np.float32)


def _environment(scenario: Scenario, trace: Trace, idx: list[int]) -> np.ndarray:
    _, roles = layout_from_scenario(scenario)
    robot = next(a for a in trace.actors.values() if a.kind == "robot")
    target = trace.actors[roles.target]
    ee = _cols(robot, ["ee_x", "ee_y", "ee_z"], idx)
    handle = _cols(target, ["handle_x", "handle_y", "handle_z"], idx)
    fraction = _cols(target, ["joint_fraction"], idx)
    n = len(idx)
    moved = roles.item or (roles.target if roles.behavior and roles.behavior.script == "carry" else None)
    item = _centre(trace.actors[moved], idx) if moved in trace.actors else np.zeros((n, 3), np.float32)
    parts = [ee, _centre(target, idx), handle if handle is not None else np.zeros((n, 3), np.float32),
             fraction if fraction is not None else np.zeros((n, 1), np.float32), item]
    if parts[0] is None:
        raise ConfigError("the trace has no end-effector position (ee_x/y/z) of the robot")
    return np.concatenate(parts, axis=1)


def _reward(scenario: Scenario, env: np.ndarray) -> np.ndarray | None:
    _, roles = layout_from_scenario(scenario)
    behavior = roles.behavior
    if behavior is None or behavior.script not in REWARD_SCRIPTS:
        return None
    n = len(env)
    after = env[np.minimum(np.arange(1, n + 1), n - 1)]  # the state the frame's action leads to
    return np.array([behavior.reward({"ee": e[0:3], "handle": e[6:9], "fraction": float(e[9])})
                     for e in after], dtype=np.float32)


def build_episode(name: str, status: str, scenario: Scenario, trace: Trace) -> Episode:
    """The episode of one verified scenario (its pictures are rendered by the writer)."""
    idx = frame_samples(trace)
    robot = next((a for a in trace.actors.values() if a.kind == "robot"), None)
    if robot is None:
        raise ConfigError(f"{name}: the trace has no robot")
    state = _cols(robot, [f"q{k}" for k in range(9)], idx)
    if state is None:
        raise ConfigError(f"{name}: the trace has no joint angles (q0..q8) of the robot")
    env = _environment(scenario, trace, idx)
    return Episode(name=name, status=status, task=task_text(scenario), samples=idx, state=state,
                   command=_cols(robot, [f"cmd_q{k}" for k in range(9)], idx), environment=env,
                   reward=_reward(scenario, env))


__all__ = ["ACTION_COMMAND", "ACTION_NEXT_STATE", "ENV_NAMES", "FPS", "STATE_NAMES", "Episode",
           "build_episode", "frame_samples", "task_text"]
