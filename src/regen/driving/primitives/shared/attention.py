"""Mental states with effects: a driver's attention bounds how long it takes to move off once
its light turns green (paper: "a distracted driver failing to move despite a green light").

A vehicle that waits ahead of a waiting ego (``drive_forward`` from ``ahead_same_lane``) with a
traffic light of the scene that turns green (or is green from the start): its departure time is tied to the light's switch
time by a delay that CP-SAT solves within its driver's bounds (:data:`START_DELAY`); a distracted
driver's FSM cause stage is ``stopped_on_green`` (stopped while the light is green for at least
the delay's lower bound), so a verified scenario shows it failing to move. Imports: the world
package only.
"""

from __future__ import annotations

from collections.abc import Sequence

from regen.driving.world.actors import ActorSpec, RoleChoice
from regen.driving.world.egos import EgoTemplate
from regen.driving.world.placement import PlacementModel

#: driver_state -> (shortest, longest) time [s] from its light turning green to moving off
START_DELAY: dict[str, tuple[float, float]] = {"attentive": (0.3, 1.2), "distracted": (1.5, 4.0)}


def _light_of(roles: Sequence[RoleChoice], t: EgoTemplate, *, distracted: bool) -> str | None:
    """The scene's first light that a waiting ego sees turn green (red at first); for a
    distracted driver also one green from the start ('fails to move despite a green light': its
    green begins at t = 0; an attentive driver at a green light would not be waiting)."""
    if not t.waits_at_start:
        return None
    states = ("red", "green") if distracted else ("red",)
    return next((r.name for r in roles if r.asset == "traffic_light" and r.properties.get("light_state") in states),
                None)


def waiting_at_green(roles: Sequence[RoleChoice], t: EgoTemplate) -> dict[str, str]:
    """Vehicle -> the light it waits at: every vehicle with a driver that waits ahead of the
    waiting ego, paired with the scene's first light that turns green (:func:`_light_of`)."""
    out = {}
    for r in roles:
        if r.primitive == "drive_forward" and r.location == "ahead_same_lane" and "driver_state" in r.properties:
            light = _light_of(roles, t, distracted=r.properties.get("driver_state") == "distracted")
            if light is not None:
                out[r.name] = light
    return out


def couple(m: PlacementModel, actors: Sequence[ActorSpec]) -> None:
    """Tie each waiting vehicle's departure to its light's green by its driver's delay."""
    by_name = {a.name: a for a in actors}
    for name, light in waiting_at_green(actors, m.ego).items():
        a = by_name[name]
        state = str(a.properties.get("driver_state", "attentive"))
        lo, hi = START_DELAY.get(state, START_DELAY["attentive"])
        t_a, t_l = m.vars.get(name, {}).get("t"), m.vars.get(light, {}).get("t")
        if by_name[light].properties.get("light_state") == "green":
            t_l = 0  # green from the start (its switch time, if solved, switches nothing)
        if t_a is None or t_l is None:
            continue
        m.require(f"{name}: moves off {lo:g} to {hi:g} s after {light} turns green ({state} driver)",
                  t_a - t_l >= int(round(lo * 10)))
        m.require(f"{name}: moves off at most {hi:g} s after {light} turns green", t_a - t_l <= int(round(hi * 10)))


def min_wait(r: RoleChoice) -> float | None:
    """How long [s] a distracted driver's vehicle stays stopped on green at least (None: an
    attentive driver, whose wait shows nothing)."""
    if r.properties.get("driver_state") != "distracted":
        return None
    return START_DELAY["distracted"][0]


__all__ = ["START_DELAY", "couple", "min_wait", "waiting_at_green"]
