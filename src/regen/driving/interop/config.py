"""The paper's config form of a driving scenario (appendix, 'Full Config Example')."""

from __future__ import annotations

from regen.core.scenario import Scenario
from regen.driving.assets import database as driving_database
from regen.driving.grounding.rules import plans_for


def paper_config(scenario: Scenario) -> dict:
    """The paper's 'Full Config Example' form of a scenario (appendix), plus the FSM states."""
    _, plans = plans_for(scenario)
    by = {p.name: p for p in plans}
    vehicles = []
    db = driving_database()
    for e in scenario.entities:
        p = by.get(e.name)
        if p is None:
            continue
        end = p.route[-1] if p.route else (p.x, p.y)
        sched = [s for _, s, _ in p.schedule] or [0.0]
        spec = db.assets.get(e.asset)
        vehicles.append({
            "name": e.name,
            "start": {"x": round(p.x, 2), "y": round(p.y, 2)},
            "end": {"x": round(end[0], 2), "y": round(end[1], 2)},
            "speed_range": [round(min(sched), 2), round(max(sched), 2)],
            "blueprint_id": (spec.blueprint if spec else "vehicle.lincoln.mkz_2020") or "",
            "driving_policy": (e.behavior or "stationary").replace("_", " "),
            "type": "dynamic" if p.dynamic else "static",
            "heading": round(p.heading * 57.29577951308232, 1),
        })
    return {
        "id": scenario.id,
        "narrative": scenario.narrative,
        "entities": [{"name": e.name, "type": e.kind, "entity_name": e.asset,
                      "properties": e.properties,
                      "behavioral_properties": {"action": e.behavior or "", **e.behavior_params}}
                     for e in scenario.entities],
        "vehicles": vehicles,
        "causal_graph": scenario.causal_graph,
        "fsm": [[[a, s] for a, s in stage] for stage in scenario.fsm.as_tuples()],
        "states": {f"{s.actor}: {s.name}": [str(c) for c in s.all_of] for s in scenario.fsm.states},
        "world": scenario.world,
        "parameters": scenario.parameters,
        "solver": scenario.solver.model_dump(),
    }


__all__ = ["paper_config"]
