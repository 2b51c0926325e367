"""What can hold in a driving scenario: the rules behind the model's predicate menu.

A predicate call that can never hold in the simulated scenario (a siren nobody has, a turn by
an actor that drives straight, a speed above the actor's speed class) is left out of the menu
the model sees (:func:`available`) and rejected, with the reason, when an answer names it
(:func:`never_holds`, used by the schemas of :mod:`regen.driving.grounding.answers`).
"""

from __future__ import annotations

from regen.core.scenario import PredicateCall
from regen.driving.primitives import for_actor, is_state_only
from regen.driving.world.actors import PEDESTRIAN_ASSETS, RoleChoice
from regen.driving.world.egos import EgoTemplate
from regen.driving.world.maps import geometry
from regen.driving.world.properties import state_schedules
from regen.verify.predicates import PredicateSpec, list_predicates

# Left out of the model's menu: `state_is` duplicates the property predicates with free-text
# keys, and `collided`, `collides` and `collision` ask for a crash that placements are solved to
# avoid (they stay in the library for verification and behavior tests); `stopped_on_green` is a
# cause stage the rules write for a distracted driver at its light (regen.driving.primitives.shared.attention).
HIDDEN_PREDICATES = {"state_is", "collided", "collides", "collision", "stopped_on_green"}
_PROPERTY_PREDICATES = {"siren_on", "door_open", "hazard_lights_on", "light_is", "signal_degraded",
                        "perceived_error_above"}


def menu(domain: str = "driving") -> list[PredicateSpec]:
    """The predicates the model may choose from."""
    return [s for s in list_predicates(domain) if s.name not in HIDDEN_PREDICATES]


def light_values(role: RoleChoice, template: EgoTemplate) -> set[str]:
    """What a traffic light shows during the scenario."""
    sched = state_schedules(role, {}, template).get("light_state", [])
    return {str(v) for _, v in sched}


def never_holds(call: PredicateCall, roles: dict[str, RoleChoice], template: EgoTemplate) -> str | None:
    """Why ``call`` (not negated) can never hold in the simulated scenario, or None.

    Conservative: it names only what the primitives, properties and map rule out for sure.
    """
    if call.negate:
        return None
    a = call.args[0] if call.args else ""
    name = call.name
    junction = geometry(template.map).junction
    if name == "in_junction" and not junction:
        return f"{call} never holds: the map ({template.map}) has no junction"
    if a == "ego":
        return _ego_never(call, template)
    r = roles.get(a)
    if r is None:
        return None
    spec = for_actor(r.asset, r.primitive)
    top = top_speed(r)
    if name in ("moving", "steady") and top is not None and _min_speed(call) >= top:
        return f"{call} never holds: {a} ({r.speed_class}) moves at most {top:g} m/s"
    why = spec.never_holds(name, r)
    if why:
        return f"{call} never holds: {why}"
    props = r.properties
    if name == "siren_on" and props.get("siren") != "on":
        return f"{call} never holds: {a} has no siren switched on (siren={props.get('siren', 'unset')})"
    if name == "door_open" and props.get("door") not in ("open", "opens"):
        return f"{call} never holds: {a}'s door stays closed"
    if name == "hazard_lights_on" and props.get("hazard_lights") != "on":
        return f"{call} never holds: {a} has no hazard lights on"
    if name == "brake_lights_on" and (r.asset in PEDESTRIAN_ASSETS or is_state_only(r.asset)
                                      or not spec.moves or props.get("brake_lights") == "broken"):
        return f"{call} never holds: {a} shows no brake lights"
    if name == "light_is":
        if r.asset != "traffic_light":
            return f"{call} never holds: {a} is not a traffic light"
        values = light_values(r, template)
        want = str(call.params.get("value", "red"))
        if want not in values:
            shown = ", ".join(sorted(values)) or "nothing"
            return f"{call} never holds: {a} shows {shown}"
    if name in ("signal_degraded", "perceived_error_above"):
        bad = {k: v for k, v in props.items() if k in ("gnss_signal", "camera_view")
               and v not in ("nominal", "clear")}
        if not bad:
            return f"{call} never holds: {a} has no degraded signal"
    return None


def _min_speed(call: PredicateCall) -> float:
    default = 0.5 if call.name == "moving" else 2.0
    return float(call.params.get("min_speed", default))


def top_speed(r: RoleChoice) -> float | None:
    """The highest speed [m/s] the solver may give the actor (None: it has no speed of its own)."""
    spec = for_actor(r.asset, r.primitive)
    if is_state_only(r.asset) or not spec.moves:
        return None
    return spec.speed_classes(r.asset).range(r.speed_class, default="fast")[1]


def _ego_never(call: PredicateCall, t: EgoTemplate) -> str | None:
    name = call.name
    top = max([t.speed0] + [v for _, v, _ in t.schedule])
    if name in ("moving", "steady") and _min_speed(call) >= top:
        return f"{call} never holds: the ego drives at most {top:g} m/s"
    never = t.never_holds(call)
    if never:
        return never
    if name == "on_sidewalk":
        return f"{call} never holds: the ego {t.description}"
    if name in _PROPERTY_PREDICATES:
        return f"{call} never holds: the ego has no such property in this toolkit"
    return None


_LOWER = {"moving": ("min_speed", 0.5), "steady": ("min_speed", 2.0)}  # speed above
_UPPER = {"slower_than": ("max_speed", 5.0), "stopped": ("max_speed", 0.3)}  # speed below


def contradiction(calls: list[PredicateCall]) -> str | None:
    """Why the calls of one state can never hold at one instant (a call and its negation, a
    speed above a bound and below a lower one, close within less than far apart), or None."""
    seen = {(c.name, tuple(c.args), tuple(sorted(c.params.items())), c.negate): c for c in calls}
    for (name, args, params, neg), c in seen.items():
        if (name, args, params, not neg) in seen:
            return f"{c} and its negation cannot hold at once"
    pos = [c for c in calls if not c.negate]
    for a in pos:  # one categorical value at a time: a light red and green at once
        for b in pos:
            if a.name == b.name and a.args == b.args:
                for k, v in a.params.items():
                    if isinstance(v, str) and k in b.params and b.params[k] != v:
                        return f"{a} and {b} cannot hold at once"
    for lo in pos:
        for hi in pos:
            if lo.name in _LOWER and hi.name in _UPPER and lo.args == hi.args:
                v_lo = float(lo.params.get(*_LOWER[lo.name]))
                v_hi = float(hi.params.get(*_UPPER[hi.name]))
                if v_lo >= v_hi:
                    return (f"{lo} (faster than {v_lo:g} m/s) and {hi} (slower than {v_hi:g} m/s) "
                            "cannot hold at once")
            if (lo.name == "close_to" and hi.name == "far_from"
                    and sorted(lo.args) == sorted(hi.args)):
                near, far = float(lo.params.get("distance", 10.0)), float(hi.params.get("distance", 30.0))
                if far >= near:
                    return f"{lo} (within {near:g} m) and {hi} (more than {far:g} m) cannot hold at once"
    return None


def available(roles: list[RoleChoice], template: EgoTemplate) -> list[PredicateSpec]:
    """The menu without predicates that can hold for no actor of this scenario (no siren
    predicate without a siren), so the prompt stays short and the choice easier."""
    actors = ["ego"] + [r.name for r in roles]
    by_name = {r.name: r for r in roles}
    out = []
    for spec in menu():
        for a in actors:
            other = [x for x in actors if x != a][:1]
            if spec.arity == 2 and not other:
                continue
            call = PredicateCall(name=spec.name, args=[a] + other[: spec.arity - 1])
            if spec.name == "light_is":
                r = by_name.get(a)
                if r is None or r.asset != "traffic_light" or not light_values(r, template):
                    continue
            elif never_holds(call, by_name, template) is not None:
                continue
            out.append(spec)
            break
    return out


__all__ = ["HIDDEN_PREDICATES", "available", "contradiction", "light_values", "menu", "never_holds", "top_speed"]
