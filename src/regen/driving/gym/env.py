"""``regen/Driving-v0``: the verified driving scenarios of generated runs as a Gymnasium env.

An episode is one verified scenario of the given run folders, simulated in Scenic's Newtonian
model with the ego driven by the agent's actions and every other actor on its scripted
behavior; unverified scenarios are skipped. Observation and action: see
:mod:`regen.driving.gym.observation` (a flat float32 Box; the action is ``[acceleration [m/s^2],
curvature [1/m]]`` with the meaning of :class:`regen.driving.testing.policies.Action`, or the same
in [-1, 1] with ``normalize_actions=True``). One step is the scenario's step (0.1 s).

Reward per step: ``progress_reward`` per metre advanced along the scenario's route, minus
``collision_penalty`` when the ego collides (the episode terminates), minus
``infraction_penalty`` when it starts an infraction (running a red light, leaving the road).
The episode is truncated at the scenario's duration.

``info`` every step: ``scenario`` (folder name), ``t`` [s], ``progress`` [m] along the route,
``collision`` (bool), ``collision_with``, ``min_ttc`` [s] so far (inf: nothing approached),
``infractions`` so far; at the episode's end also ``verdict``: the behavior test's
:class:`~regen.harness.cases.CaseResult` of the episode as a dict (``status``,
``cause``, ``message``, ``robot_stages`` with the time each FSM ego state was reached).
Per-step safety values are estimated from the observations; the verdict comes from the
recorded trace (:func:`regen.driving.verify.collisions.analyze`), as ``regen test`` judges.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import weakref
from pathlib import Path

import gymnasium as gym
import numpy as np

from regen.driving.gym import observation as ob
from regen.driving.gym.episode import Episode
from regen.driving.testing.policies import Observation
from regen.driving.verify.collisions import LIGHT_REACH, MIN_CLOSING_SPEED, to_stop_line
from regen.driving.world.geometry import corners, door_footprint, gap, overlap
from regen.errors import ConfigError, SimulationError
from regen.harness.catalog import Entry, Picker, verified

PROGRESS_REWARD = 0.1  # reward per metre along the route [1/m]
COLLISION_PENALTY = 10.0  # subtracted when the ego collides (the episode terminates)
INFRACTION_PENALTY = 2.0  # subtracted when an infraction starts (red light, off road)
DOMAIN = "driving"
ORDERS = ("random", "cycle")


class _Route:
    """Arc length [m] of the ego's position along the scenario's route polyline."""

    def __init__(self, points):
        p = np.asarray(points, dtype=float).reshape(-1, 2)
        if len(p) < 2:
            p = np.vstack([p, p + [1.0, 0.0]]) if len(p) else np.array([[0.0, 0.0], [1.0, 0.0]])
        self.a, d = p[:-1], np.diff(p, axis=0)
        self.len = np.hypot(d[:, 0], d[:, 1])
        self.u = d / np.maximum(self.len, 1e-9)[:, None]
        self.s0 = np.concatenate([[0.0], np.cumsum(self.len)[:-1]])

    def locate(self, x: float, y: float, near: float | None = None) -> float:
        """Arc length of the nearest route point; with ``near`` only within [near-5, near+30] m
        (a route that comes back near itself must not make the ego jump)."""
        r = np.array([x, y]) - self.a
        lon = np.sum(r * self.u, axis=1)
        first, last = np.arange(len(self.a)) == 0, np.arange(len(self.a)) == len(self.a) - 1
        lon = np.where(first, np.minimum(lon, self.len), np.where(last, np.maximum(lon, 0.0),
                                                                   np.clip(lon, 0.0, self.len)))
        dist = np.hypot(*(r - lon[:, None] * self.u).T)
        s = self.s0 + lon
        if near is not None:
            dist = np.where((s >= near - 5.0) & (s <= near + 30.0), dist, np.inf)
            if not np.isfinite(dist).any():
                return near
        return float(s[int(np.argmin(dist))])


class _Safety:
    """Collisions, infractions and TTC of the ego step by step from observations (as
    :mod:`regen.driving.verify.collisions` does on a whole trace)."""

    def __init__(self, geometry):
        self.geo = geometry
        self.collision_with: str | None = None
        self.min_ttc = math.inf
        self.infractions: list[str] = []
        self.on_road = True
        self.prev: Observation | None = None

    def update(self, obs: Observation) -> tuple[bool, int]:
        """(the ego collides now, infractions that start now)."""
        from regen.driving.simulation.record import map_facts

        ego = obs.ego
        new = 0
        on_road = bool(map_facts(self.geo, ego.x, ego.y)[1])
        if self.on_road and not on_road:
            self.infractions.append(f"ego left the road at t={obs.t:.1f} s")
            new += 1
        self.on_road = on_road
        hit_now = False
        ce = corners(ego.x, ego.y, ego.heading, ego.length, ego.width)
        evx, evy = ego.speed * math.cos(ego.heading), ego.speed * math.sin(ego.heading)
        for a in obs.actors:
            if a.category == "light" or a.length <= 0 or a.width <= 0:
                continue
            x, y, w = (float(v) for v in door_footprint(a.x, a.y, a.heading, a.width, a.door == "open"))
            if overlap(ego.x, ego.y, ego.heading, ego.length, ego.width, x, y, a.heading, a.length, w):
                hit_now, self.min_ttc = True, 0.0
                if self.collision_with is None:
                    self.collision_with = a.name
                continue
            rx, ry = x - ego.x, y - ego.y
            closing = -(rx * (a.vx - evx) + ry * (a.vy - evy)) / max(math.hypot(rx, ry), 1e-9)
            if closing > MIN_CLOSING_SPEED:
                ca = corners(x, y, a.heading, a.length, w)
                self.min_ttc = min(self.min_ttc, float(gap(ce, ca)) / closing)
        if self.prev is not None:
            new += self._red_lights(self.prev, obs)
        self.prev = obs
        return hit_now, new

    def _red_lights(self, prev: Observation, obs: Observation) -> int:
        """Red lights whose stop line the ego crossed between ``prev`` and ``obs``, as
        :func:`regen.driving.verify.collisions.red_light_events` finds them in a trace."""
        new = 0
        for a in obs.actors:
            if a.category != "light" or a.light_state != "red":
                continue
            (lon0, _), (lon1, lat1) = _stop_line(prev.ego, a), _stop_line(obs.ego, a)
            if lon0 > 0 >= lon1 and abs(lat1) <= LIGHT_REACH:
                self.infractions.append(f"ego ran the red light {a.name} at t={obs.t:.1f} s")
                new += 1
        return new


def _stop_line(ego, light) -> tuple[float, float]:
    """(distance [m] from the ego's front to the light's stop line, the light's lateral offset [m])."""
    lon, lat = to_stop_line(ego.x, ego.y, ego.heading, ego.length, light.x, light.y)
    return float(lon), float(lat)


class DrivingEnv(gym.Env):
    """Episodes are the verified driving scenarios of ``runs`` (run folder paths).

    ``order``: 'random' (seeded by ``reset(seed=...)``) or 'cycle' (round robin; a seeded reset
    starts at ``seed % n``); ``reset(options={"scenario": NAME})`` picks one by name.
    ``normalize_actions``: actions in [-1, 1] (see :func:`regen.driving.gym.observation.decode_action`).
    ``oracle``: how the final verdict judges ('fsm' or 'safety', as ``regen test``).
    ``variants``: parameter variants per scenario; only 1 so far. Scenic runs one simulation
    per process: vectorize with subprocesses (AsyncVectorEnv, SubprocVecEnv).
    """

    metadata = {"render_modes": []}

    def __init__(self, runs, *, order: str = "random", normalize_actions: bool = False,
                 progress_reward: float = PROGRESS_REWARD, collision_penalty: float = COLLISION_PENALTY,
                 infraction_penalty: float = INFRACTION_PENALTY, oracle: str = "fsm", variants: int = 1,
                 render_mode: str | None = None):
        if render_mode is not None:
            raise ConfigError(f"regen/Driving-v0 renders nothing (render_mode={render_mode!r}); "
                              "the run folder's pictures show the scenarios")
        if order not in ORDERS:
            raise ConfigError(f"unknown order {order!r}; choose one of: {', '.join(ORDERS)}")
        if variants != 1:
            raise ConfigError("variants other than 1 are not implemented yet")
        self.render_mode = None
        self.entries, self.skipped = verified(runs, DOMAIN)
        self._picker = Picker(self.entries, order)
        if not self.entries:
            where = ", ".join(str(r) for r in ([runs] if isinstance(runs, (str, Path)) else runs))
            raise ConfigError(f"no verified driving scenario in {where} ({len(self.skipped)} did not "
                              "verify): an episode needs a scenario that verified with the template "
                              "ego (regen generate makes them)")
        self.order, self.normalize_actions, self.oracle = order, normalize_actions, oracle
        self.progress_reward, self.collision_penalty = progress_reward, collision_penalty
        self.infraction_penalty = infraction_penalty
        self.observation_space = ob.observation_space()
        self.action_space = ob.action_space(normalize_actions)
        self._slot: dict[str, Episode | None] = {"episode": None}
        self._finalizer = weakref.finalize(self, _stop_slot, self._slot)  # no thread outlives the env
        self._entry: Entry | None = None

    @property
    def scenario_names(self) -> list[str]:
        return [e.name for e in self.entries]

    @property
    def policy_observation(self) -> Observation | None:
        """The latest observation as :mod:`regen.driving.testing.policies` types, so a built-in or
        scripted policy can drive the env (demonstrations, baselines); None before reset."""
        return getattr(self, "_last", None)

    # --- the episode ---------------------------------------------------------------------------

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        _stop_slot(self._slot)
        entry = self._picker.pick(options, self.np_random, seed)
        # the episode must not reference self: the finalizer holds it, and would keep self alive
        episode = Episode(functools.partial(_prepared, entry))
        obs = episode.start()
        if obs is None:
            episode.stop()
            why = episode.error or (episode.run.failure if episode.run else "it ended at once")
            raise SimulationError(f"scenario {entry.name} could not be simulated: {why}")
        from regen.driving.world.maps import geometry

        prep = episode.prepared
        self._slot["episode"], self._entry = episode, entry
        self._steps, self._duration = 0, prep.steps * prep.dt
        self._route = _Route(prep.template.route)
        self._s = self._route.locate(obs.ego.x, obs.ego.y)
        self._safety = _Safety(geometry(prep.map_name))
        self._safety.update(obs)
        self._last = obs
        return self._encode(obs), self._info(obs)

    def step(self, action):
        episode = self._slot["episode"]
        if episode is None or not episode.alive:
            raise gym.error.ResetNeeded("call reset() before step() (the episode has ended)")
        obs = episode.step(ob.decode_action(action, self.normalize_actions))
        ended_itself = obs is None
        obs = self._last if obs is None else obs
        self._steps += 1
        reward, terminated = 0.0, False
        if not ended_itself:
            s = self._route.locate(obs.ego.x, obs.ego.y, near=self._s)
            reward += self.progress_reward * (s - self._s)
            self._s = s
            hit, new = self._safety.update(obs)
            reward -= self.infraction_penalty * new
            if hit:
                reward -= self.collision_penalty
                terminated = True
        truncated = not terminated and (ended_itself or self._steps >= self._entry.prepared.steps)
        self._last = obs
        info = self._info(obs)
        if terminated or truncated:
            info.update(self._finish(episode))
        return self._encode(obs), float(reward), terminated, truncated, info

    def _finish(self, episode: Episode) -> dict:
        """End the simulation; the behavior test's verdict of the episode."""
        from regen.core.trace import Trace
        from regen.driving.testing.harness import DrivingHarness
        from regen.harness.oracle import judge
        from regen.runfolder import read_model

        self._slot["episode"] = None
        run = episode.stop()
        if run is None or run.trace is None:
            why = episode.error if episode.error is not None else "no trace"
            return {"error": f"{type(why).__name__}: {why}" if isinstance(why, BaseException) else why}
        if run.failure_kind == "exception" and "EpisodeAborted" in (run.failure or ""):
            run = dataclasses.replace(run, failure=None, failure_kind=None, failure_time=None)
        entry = self._entry
        if entry.template_trace is None:
            entry.template_trace = read_model(entry.folder / entry.folder.TRACE, Trace).value
        case = judge(DrivingHarness(), entry.scenario, run, folder=entry.name, oracle=self.oracle,
                     template_trace=entry.template_trace)
        out = {"verdict": case.model_dump(mode="json")}
        if episode.error is not None:
            out["error"] = f"{type(episode.error).__name__}: {episode.error}"
        return out

    def _encode(self, obs: Observation) -> np.ndarray:
        return ob.encode(obs, max(self._duration - obs.t, 0.0))

    def _info(self, obs: Observation) -> dict:
        sf = self._safety
        return {"scenario": self._entry.name, "t": float(obs.t), "progress": float(self._s),
                "collision": sf.collision_with is not None, "collision_with": sf.collision_with,
                "min_ttc": float(sf.min_ttc), "infractions": list(sf.infractions)}

    def close(self):
        _stop_slot(self._slot)
        super().close()


def _prepared(entry: Entry):
    if entry.prepared is None:
        from regen.driving.testing.loop import prepare

        entry.prepared = prepare(entry.scenario)
    return entry.prepared


def _stop_slot(slot: dict) -> None:
    episode = slot.get("episode")
    slot["episode"] = None
    if episode is not None:
        episode.stop()


__all__ = ["COLLISION_PENALTY", "INFRACTION_PENALTY", "PROGRESS_REWARD", "DrivingEnv"]
