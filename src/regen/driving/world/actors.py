"""The actors around the ego: what grounding chose for each, and facts about their assets.

A :class:`RoleChoice` is one actor as grounding decided it (asset, motion primitive, start
location, speed class, property values, and which of these the causal graph fixed); an
:class:`ActorSpec` adds the asset's size, which the solver and the planner need. What a primitive does lives in :mod:`regen.driving.primitives`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

# Assets that walk: they stand on sidewalks, use the walking speed classes, and are Scenic
# Pedestrians.
PEDESTRIAN_ASSETS = frozenset({"adult", "child", "pedestrian_group", "police_officer", "road_worker"})
# Static objects that are vehicles: a Scenic Car, parked half on the curb.
PARKED_ASSETS = frozenset({"parked_car"})
# Assets that are traffic lights: no footprint that collides, a light state the ego must obey.
LIGHT_ASSETS = frozenset({"traffic_light"})
# What :func:`actor_category` returns (sensors ride on an actor and are never observed or checked).
CATEGORIES = ("vehicle", "pedestrian", "static", "light", "sensor")
# The graph's properties that say how an actor moves; the ones it sets are binding on grounding.
GRAPH_CHOICES = ("behavior", "start_location", "target_speed")


@dataclass(frozen=True, kw_only=True)
class RoleChoice:
    """One actor as grounding decided it."""

    name: str
    asset: str
    primitive: str  # motion primitive ('' or 'stationary' for lights and sensors)
    location: str  # start location, relative to the ego
    speed_class: str  # 'slow', 'moderate' or 'fast'
    properties: dict[str, str] = field(default_factory=dict)
    # what the causal graph decided, binding on grounding: a subset of GRAPH_CHOICES (the
    # property values in ``properties`` always come from the graph)
    fixed: frozenset[str] = frozenset()

    def graph_choices(self) -> dict[str, str]:
        """The graph's fixed choices of this actor as {property: value}, e.g.
        {'behavior': 'cross_the_road', 'start_location': 'roadside_ahead'}."""
        values = {"behavior": self.primitive, "start_location": self.location,
                  "target_speed": self.speed_class}
        return {k: values[k] for k in GRAPH_CHOICES if k in self.fixed}


@dataclass(frozen=True, kw_only=True)
class ActorSpec(RoleChoice):
    """What the solver and the planner need about one non-ego actor."""

    size: tuple[float, float, float]  # length, width, height [m]


def actor_category(asset: str, kind: str) -> str:
    """'vehicle', 'pedestrian', 'static', 'light' or 'sensor' of an actor from its asset and its
    database ``kind`` ('agent', 'object', 'sensor', 'ego'): what collisions, observations and
    pictures tell apart. The ego is a 'vehicle'."""
    if kind == "sensor":
        return "sensor"
    if asset in PEDESTRIAN_ASSETS:
        return "pedestrian"
    if asset in LIGHT_ASSETS:
        return "light"
    if kind == "object":
        return "static"
    return "vehicle"


def scenic_class(asset: str, kind: str) -> str:
    """The Scenic class of an asset of database ``kind`` ('' for sensors: not Scenic objects)."""
    cat = actor_category(asset, kind)
    if cat == "sensor":
        return ""
    if cat == "pedestrian":
        return "Pedestrian"
    if cat in ("static", "light") and asset not in PARKED_ASSETS:
        return "Object"
    return "Car"


__all__ = ["CATEGORIES", "GRAPH_CHOICES", "LIGHT_ASSETS", "PARKED_ASSETS", "PEDESTRIAN_ASSETS", "ActorSpec",
           "RoleChoice", "actor_category", "scenic_class"]
