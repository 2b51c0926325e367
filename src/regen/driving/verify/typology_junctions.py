"""The junction rules of the NHTSA pre-crash typology (:mod:`regen.driving.verify.typology`):
signals and signs (5, 6) and the crossing, turning and left-turn-across-path classes (28-32),
from the meetings of the ego and other vehicles at the junction."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from regen.driving.verify.typology_scene import (
    MOVING,
    NEAR_IN_TIME,
    OPPOSITE,
    SAME_DIRECTION,
    STANDING,
    Scene,
    Track,
    first_time,
    named,
    net_turn,
    steps,
    wrap,
)

TURNED = math.radians(45)  # net heading change that makes a passage a turn
STOP_SIGN_REACH = 15.0  # [m] a stop sign governs the junction entry this close to it


# -- 5, 6: signals and signs ----------------------------------------------------------------------


def _entries(scene: Scene, t: Track) -> list[int]:
    """Steps at which ``t`` drives into the junction."""
    inside = scene.in_junction(t)
    return [int(k) for k in np.flatnonzero(inside[1:] & ~inside[:-1]) + 1]


def _ego_there(scene: Scene, k: int) -> bool:
    """Whether the ego approaches the junction, or is in it, driving, around step ``k``."""
    lo, hi = max(0, k - steps(NEAR_IN_TIME, scene.dt)), k + steps(NEAR_IN_TIME, scene.dt) + 1
    return bool((scene.approaching(scene.ego) & scene.driving())[lo:hi].any())


def running_red_light(scene: Scene) -> list[str]:
    """A vehicle (the ego or another, as the ego approaches) drives into the junction while a
    traffic light shows red; or, at a junction with a light, the ego and a vehicle from the cross
    street go straight into each other's path (one of them has red)."""
    lights = [t for t in scene.others if "light_state" in t.states]
    if not lights:
        return []
    red = np.zeros(scene.n, dtype=bool)
    for light in lights:
        red |= light.equals("light_state", "red")
    out = []
    for v in (scene.ego, *scene.of_kind("vehicle")):
        for k in _entries(scene, v):
            if red[k] and v.v[k] > MOVING and (v is scene.ego or _ego_there(scene, k)):
                who = "the ego" if v is scene.ego else named(v)
                out.append(f"{who} drives into the junction on red at t = {k * scene.dt:.1f} s")
                break
    for m in meetings(scene):
        if m.relation == "crossing" and m.ego_turn == m.other_turn == "straight":
            out.append(f"{named(m.other)} and the ego cross the signalized junction's paths straight "
                       f"at t = {m.at:.1f} s")
    return out


def running_stop_sign(scene: Scene) -> list[str]:
    """A vehicle drives into the junction past a stop sign (entering within
    :data:`STOP_SIGN_REACH` of it) without having stood in the seconds before."""
    out = []
    before = steps(NEAR_IN_TIME, scene.dt)
    for sign in scene.of_kind("stop_sign"):
        for v in (scene.ego, *scene.of_kind("vehicle")):
            for k in _entries(scene, v):
                near = math.hypot(v.x[k] - sign.x[k], v.y[k] - sign.y[k]) <= STOP_SIGN_REACH
                stood = bool((v.v[max(0, k - before):k + 1] < STANDING).any())
                if near and not stood and (v is scene.ego or _ego_there(scene, k)):
                    who = "the ego" if v is scene.ego else named(v)
                    out.append(f"{who} passes {sign.name} without stopping at t = {k * scene.dt:.1f} s")
    return out


# -- 28-32: junctions -----------------------------------------------------------------------------


@dataclass(frozen=True)
class Meeting:
    """The ego and another vehicle at the junction at once: how they came (relation of their
    approach headings: same, opposite, crossing) and how each passes (left, right, straight)."""

    other: Track
    relation: str
    ego_turn: str
    other_turn: str
    at: float  # [s] the first step both were there


def _approach_step(scene: Scene, t: Track) -> int:
    """The step :data:`NEAR_IN_TIME` before ``t`` first drives into the junction (0 if it never does)."""
    inside = scene.in_junction(t)
    return max(0, int(np.argmax(inside)) - steps(NEAR_IN_TIME, scene.dt)) if inside.any() else 0


def junction_turn(scene: Scene, t: Track) -> str:
    """How ``t`` passes the junction: 'left', 'right' or 'straight' (also when it never enters)."""
    inside = scene.in_junction(t)
    if not inside.any():
        return "straight"
    idx = np.flatnonzero(inside)
    turn = net_turn(t, _approach_step(scene, t), int(idx[-1]) + steps(1.0, scene.dt))
    return "left" if turn >= TURNED else "right" if turn <= -TURNED else "straight"


def meetings(scene: Scene) -> list[Meeting]:
    """Vehicles that are in the junction while the driving ego approaches it or is in it, or
    approach it while the ego drives through it."""
    if scene.junction is None:
        return []
    ego = scene.ego
    ego_in = scene.in_junction(ego) & (ego.v > STANDING)
    ego_near = scene.approaching(ego) & scene.driving()
    h_ego = ego.h[_approach_step(scene, ego)]
    out = []
    for t in scene.of_kind("vehicle"):
        meet = (scene.in_junction(t) & (t.v > STANDING) & ego_near) | (ego_in & scene.approaching(t))
        if not meet.any():
            continue
        rel = abs(float(wrap(t.h[_approach_step(scene, t)] - h_ego)))
        relation = "same" if rel < SAME_DIRECTION else "opposite" if rel > OPPOSITE else "crossing"
        out.append(Meeting(t, relation, junction_turn(scene, ego), junction_turn(scene, t), first_time(scene, meet)))
    return out


def _ltap(scene: Scene, *, signalized: bool) -> list[str]:
    if scene.signalized != signalized:
        return []
    out = []
    for m in meetings(scene):
        turns = (m.ego_turn, m.other_turn)
        if m.relation == "opposite" and "left" in turns and turns != ("left", "left"):
            who = "the ego" if m.ego_turn == "left" else named(m.other)
            out.append(f"{who} turns left across the oncoming "
                       f"{named(m.other) if who == 'the ego' else 'ego'}'s path at t = {m.at:.1f} s")
    return out


def ltap_od_signalized(scene: Scene) -> list[str]:
    return _ltap(scene, signalized=True)


def ltap_od_non_signalized(scene: Scene) -> list[str]:
    return _ltap(scene, signalized=False)


def right_turn_signalized(scene: Scene) -> list[str]:
    """At a junction with a light, the ego or a vehicle from the cross street turns right while
    the other is there."""
    if not scene.signalized:
        return []
    return [f"{'the ego' if m.ego_turn == 'right' else named(m.other)} turns right across the cross "
            f"traffic's path at t = {m.at:.1f} s"
            for m in meetings(scene) if m.relation == "crossing" and "right" in (m.ego_turn, m.other_turn)]


def straight_crossing_paths_non_signalized(scene: Scene) -> list[str]:
    """At a junction without a light, the ego and a vehicle from the cross street both go straight."""
    if scene.signalized:
        return []
    return [f"{named(m.other)} crosses the ego's path straight at the junction at t = {m.at:.1f} s"
            for m in meetings(scene) if m.relation == "crossing" and m.ego_turn == m.other_turn == "straight"]


def turning_non_signalized(scene: Scene) -> list[str]:
    """At a junction without a light, the ego or a vehicle from the cross street turns while the
    other is there."""
    if scene.signalized:
        return []
    return [f"{'the ego' if m.ego_turn != 'straight' else named(m.other)} turns "
            f"{m.ego_turn if m.ego_turn != 'straight' else m.other_turn} into the cross traffic's path "
            f"at t = {m.at:.1f} s"
            for m in meetings(scene) if m.relation == "crossing" and (m.ego_turn, m.other_turn) != ("straight",) * 2]


#: the rules of this module, each named as its class's id
RULES = (running_red_light, running_stop_sign, ltap_od_signalized, right_turn_signalized, ltap_od_non_signalized,
         straight_crossing_paths_non_signalized, turning_non_signalized)

__all__ = ["RULES", "STOP_SIGN_REACH", "TURNED", "Meeting", "junction_turn", "ltap_od_non_signalized", "ltap_od_signalized",
           "meetings", "right_turn_signalized", "running_red_light", "running_stop_sign",
           "straight_crossing_paths_non_signalized", "turning_non_signalized"]
