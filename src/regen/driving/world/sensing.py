"""The ego's sensors with effects (paper: "braking due to faulty GPS").

A sensor (GNSS receiver, front camera) rides on the ego; its signal state is scheduled like any
cause state (switched at a CP-SAT-solved time, on the clock of the trigger that makes it happen
where the ego's event is). What the ego *perceives* follows from it, the same function in the
Scenic program and in the recorded trace:

- GNSS: the perceived position is off the true one, to the ego's left, by an error that is
  :data:`NOMINAL_ERROR` while the signal is nominal and grows at a rate up to a magnitude of its
  degraded value (noisy: 4 m/s up to 6 m; jammed: 15 m/s up to 30 m).
- camera: the share of the view lost grows at a rate up to a magnitude (glare: 2/s up to 0.8;
  occluded: 5/s up to 1.0).

The ego trusts its localisation within :data:`LIMITS` ``gnss`` (2 m) and its camera while it
loses less than half the view. An ego template whose reaction is in its speed schedule (stops,
slow-downs) holds its cruise phase until the perceived error crosses that limit, and reacts
:data:`REACTION_DELAY` later: without the degraded signal it never reacts, so a scenario that
verifies shows the ego braking *because* of what it perceived.

Imports: this package's triggers and plans only.
"""

from __future__ import annotations

import functools
import inspect
from dataclasses import dataclass

from regen.driving.world.egos import EgoTemplate
from regen.driving.world.plan import ActorPlan
from regen.driving.world.triggers import Spec

NOMINAL_ERROR = 0.3  # [m] GNSS position error with a nominal signal
NEVER = 1e6  # [s] the switch time of a signal that stays nominal
REACTION_DELAY = 0.3  # [s] from the perceived error crossing the limit to the ego's reaction
#: sensor state -> (state value -> (growth per second, magnitude)); GNSS in metres, camera a share
EFFECTS: dict[str, dict[str, tuple[float, float]]] = {
    "gnss_signal": {"noisy": (4.0, 6.0), "jammed": (15.0, 30.0)},
    "camera_view": {"glare": (2.0, 0.8), "occluded": (5.0, 1.0)},
}
BASE = {"gnss_signal": NOMINAL_ERROR, "camera_view": 0.0}
LIMITS = {"gnss_signal": 2.0, "camera_view": 0.5}  # beyond these the ego does not trust the sensor
#: the trace state a sensor's perceived error is recorded in
ERROR_STATE = {"gnss_signal": "gnss_error", "camera_view": "view_lost"}


@dataclass(frozen=True)
class Effect:
    """What a sensor's degraded signal does: its state key, when it degrades (template time on
    the sensor's clock) and how the perceived error grows."""

    key: str  # 'gnss_signal' or 'camera_view'
    t_switch: float  # [s] template time of the first degraded value
    rate: float  # growth per second
    magnitude: float
    base: float
    limit: float

    def spec(self) -> tuple[float, float, float, float, float]:
        return (self.t_switch, self.rate, self.magnitude, self.base, self.limit)


def perceived_error(since: float, rate: float, magnitude: float, base: float) -> float:
    """The perceived error ``since`` [s] after the signal degraded (negative: not yet)."""
    if since < 0.0:
        return base
    return max(base, min(magnitude, rate * since))


def effect_of(plan: ActorPlan) -> Effect | None:
    """The effect of a sensor plan's scheduled signal (a signal nominal all along never degrades:
    the ego that reacts to it never reacts), or None for other plans."""
    if plan.kind != "sensor":
        return None
    for key, table in EFFECTS.items():
        for t, value in plan.states.get(key, []):
            if value in table:
                rate, magnitude = table[value]
                return Effect(key, float(t), rate, magnitude, BASE[key], LIMITS[key])
        if key in plan.states:
            return Effect(key, NEVER, 0.0, BASE[key], BASE[key], LIMITS[key])
    return None


def reacts_in_schedule(template: EgoTemplate) -> bool:
    """Whether the template's reaction is a change of its speed schedule at its event (a stop or
    a slow-down): then holding the schedule holds the reaction."""
    return not template.replay and any(abs(t - template.t_event) < 1e-6 for t, _, _ in template.schedule)


def sensing_spec(plans: list[ActorPlan], template: EgoTemplate) -> tuple | None:
    """(sensor trigger spec, t_switch, rate, magnitude, base, limit, t_event, delay) for the ego
    of ``plans`` to react to, or None: the first degraded sensor, if the ego's reaction can wait."""
    if not reacts_in_schedule(template):
        return None
    for p in plans:
        eff = effect_of(p)
        if eff is not None:
            trigger: Spec | None = p.trigger.spec() if p.trigger is not None else None
            return (trigger, *eff.spec(), template.t_event, REACTION_DELAY)
    return None


def ego_clock(sensing, reacted, t, sensor_time):
    """``(reacted, schedule time [s])`` of an ego that reacts to a sensor (``sensing`` from
    :func:`sensing_spec`) at time ``t`` [s], the sensor's clock at ``sensor_time`` [s];
    ``reacted`` is when its perceived error crossed the limit (None: not yet)."""
    _, t_switch, rate, magnitude, base, limit, t_event, delay = sensing
    error = perceived_error(sensor_time - t_switch, rate, magnitude, base)
    if reacted is None and error > limit:
        reacted = t
    if reacted is None or t < reacted + delay:
        return reacted, min(t, t_event - 1e-3)
    return reacted, t_event + (t - reacted - delay)


@functools.cache
def scenic_source() -> str:
    """:func:`perceived_error` and :func:`ego_clock` as program text, for the Scenic program
    (read once per process: ``inspect.getsource`` tokenizes the module each time)."""
    return "\n\n".join(inspect.getsource(f) for f in (perceived_error, ego_clock))


__all__ = ["EFFECTS", "ERROR_STATE", "LIMITS", "Effect", "ego_clock", "effect_of", "perceived_error",
           "scenic_source", "sensing_spec"]
