"""Mass and performance of an exported entity (OpenSCENARIO's ``mass`` and ``Performance``).

An entity's values are its asset's ``physics`` in the asset database (``assets.json``: mass
[kg], max speed [m/s], max acceleration and deceleration [m/s^2]), else the nominal values of its
OpenSCENARIO category below (the ego, which is no asset of the database, is a car; a user's
database may state none). Each limit is raised to what the actor does in the recording, so a
player that enforces them still replays the run. OpenSCENARIO 1.2 gives a pedestrian and a
misc object only a mass. The values are listed in docs/interop.md.
Imports: the shared trace and numpy.
"""

from __future__ import annotations

import math

import numpy as np

from regen.core.trace import ActorTrack

# asset -> OpenSCENARIO vehicle category; other vehicles are cars
VEHICLE_CATEGORY = {"truck": "truck", "fire_truck": "truck", "tow_truck": "truck", "bus": "bus",
                    "bicycle": "bicycle", "motorcycle": "motorbike", "ambulance": "van"}
#: mass [kg], max speed [m/s], max acceleration and deceleration [m/s^2] of an entity whose asset
#: states no ``physics`` in the database (the ego, a user's database), by OpenSCENARIO category
NOMINAL: dict[str, tuple[float, float, float, float]] = {
    "car": (1500.0, 50.0, 4.5, 9.0), "van": (3500.0, 40.0, 3.0, 8.0), "truck": (12000.0, 30.0, 1.5, 6.0),
    "bus": (15000.0, 28.0, 1.2, 6.0), "bicycle": (90.0, 12.0, 1.5, 5.0), "motorbike": (250.0, 50.0, 6.0, 8.0)}
NOMINAL_MASS = {"pedestrian": 75.0, "misc": 50.0}  # [kg]


def _ceil(v: float) -> float:
    """``v`` rounded up to 0.1."""
    return math.ceil(round(v * 10.0, 6)) / 10.0


def _recorded_limits(track: ActorTrack, dt: float) -> tuple[float, float, float]:
    """The highest speed [m/s], acceleration and deceleration [m/s^2] the trace has ``track`` at."""
    v = np.asarray(track.speed, float)
    if len(v) == 0 or not dt > 0:
        return 0.0, 0.0, 0.0
    a = np.diff(v) / dt
    return (float(np.nanmax(v)), float(np.nanmax(a, initial=0.0)), float(-np.nanmin(a, initial=0.0)))


def physics(asset: str, kind: str, db, track: ActorTrack | None = None, dt: float = 0.0
            ) -> tuple[float, float, float, float]:
    """Mass [kg], max speed [m/s], max acceleration and deceleration [m/s^2] of an entity: its
    asset's ``physics`` in the database, else the nominal values of its category
    (:data:`NOMINAL`); each limit raised to what ``track`` does in the recording, so a player that
    enforces them still replays the run. A pedestrian's and an object's limits are 0 (the
    standard gives them only a mass)."""
    spec = db.assets.get(asset) if db is not None else None
    phys = spec.physics if spec is not None else None
    if kind != "vehicle":
        return (phys.mass if phys is not None else NOMINAL_MASS[kind]), 0.0, 0.0, 0.0
    mass, v_max, a_max, d_max = NOMINAL[VEHICLE_CATEGORY.get(asset, "car")]
    if phys is not None:
        mass = phys.mass
        v_max, a_max, d_max = (phys.max_speed or v_max, phys.max_acceleration or a_max,
                               phys.max_deceleration or d_max)
    if track is not None:
        v_rec, a_rec, d_rec = _recorded_limits(track, dt)
        v_max, a_max, d_max = max(v_max, _ceil(v_rec)), max(a_max, _ceil(a_rec)), max(d_max, _ceil(d_rec))
    return mass, v_max, a_max, d_max


__all__ = ["NOMINAL", "NOMINAL_MASS", "VEHICLE_CATEGORY", "physics"]
