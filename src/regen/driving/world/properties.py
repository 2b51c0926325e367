"""Property states over time: what the Newtonian model lacks (doors, lights, sirens, sensors).

A role's property values become schedules ``[(t_from [s], value), ...]`` on its plan, in the
template ego's time; the trace records them step by step (:mod:`regen.driving.simulation.record`) for the
predicates to read, on the clock of the plan's trigger (:mod:`regen.driving.world.triggers`), so a
door opens or a light turns red as the actual ego comes near.
"""

from __future__ import annotations

from collections.abc import Mapping

from regen.driving.world.actors import RoleChoice
from regen.driving.world.egos import EgoTemplate

# Properties that say how an actor moves, not a state it shows.
MOTION_PROPERTIES = frozenset({"behavior", "start_location", "end_location", "target_speed"})
YELLOW_TIME = 2.0  # [s] of yellow before a light turns red


def state_schedules(r: RoleChoice, params: Mapping[str, float], t: EgoTemplate) -> dict[str, list]:
    """Property -> ``[(t_from [s], value), ...]`` of one actor; a state that changes does so at
    its solved trigger time ``params["t"]`` (else 1 s before the ego's event)."""
    out: dict[str, list] = {}
    ts = params.get("t", t.t_event - 1.0)
    for key, val in r.properties.items():
        if key == "door":
            out[key] = [(0.0, "closed"), (ts, "open")] if val == "opens" else [(0.0, val)]
        elif key == "light_state":
            if val == "turns_red":
                out[key] = [(0.0, "green"), (max(0.0, ts - YELLOW_TIME), "yellow"), (ts, "red")]
            elif val == "red" and t.waits_at_start:
                out[key] = [(0.0, "red"), (ts, "green")]
            else:
                out[key] = [(0.0, val)]
        elif key == "gnss_signal" and val != "nominal":
            out[key] = [(0.0, "nominal"), (ts, val)]
        elif key == "camera_view" and val != "clear":
            out[key] = [(0.0, "clear"), (ts, val)]
        elif key in MOTION_PROPERTIES:
            continue
        else:
            out[key] = [(0.0, val)]
    return out


__all__ = ["MOTION_PROPERTIES", "state_schedules"]
