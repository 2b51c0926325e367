"""The driving domain behind :class:`regen.domains.DomainBackend`.

``ground`` -> Scenario (model or rules, CP-SAT placement), ``simulate`` -> Trace (Scenic
Newtonian), ``verify`` (the shared monitor with relaxation), ``render`` (bird's-eye GIF and key
frames) and ``export`` (the .scenic program and an OpenSCENARIO replay). The pipeline
(:mod:`regen.pipeline`) calls these stages; there is no other path.
"""

from __future__ import annotations

import logging
import time
from pathlib import Path
from typing import TYPE_CHECKING

from regen.core.behavior import Behavior
from regen.core.graph import CausePath
from regen.core.io import atomic_write_text
from regen.core.scenario import Scenario
from regen.core.trace import Trace
from regen.core.verdict import Verdict
from regen.domains import DomainBackend, ReportHints, SimulationOutput, Wording
from regen.driving.assets import RESOURCE
from regen.driving.assets import database as driving_database
from regen.driving.ego import EGO_TEMPLATES, template_for
from regen.driving.ground import ground_rule_based, plans_for
from regen.driving.maps import ensure_map, geometry
from regen.driving.scenic_writer import write_program
from regen.errors import ConfigError, GroundingError

if TYPE_CHECKING:
    from regen.llm.client import LLM

log = logging.getLogger(__name__)


def _timing(scenario: Scenario) -> tuple[float, int, int]:
    """Step [s], step count and seed of a scenario's world."""
    dt = float(scenario.world.get("dt", 0.1))
    steps = int(round(float(scenario.world.get("duration", 16.0)) / dt))
    return dt, steps, int(scenario.world.get("seed", 0))


def scenic_program(scenario: Scenario) -> str:
    """The Scenic program of a grounded scenario (the map is generated if needed)."""
    _, plans = plans_for(scenario)
    dt, steps, seed = _timing(scenario)
    return write_program(plans, map_path=str(ensure_map(str(scenario.world["map"]))), dt=dt,
                         max_steps=steps, narrative=scenario.narrative, seed=seed,
                         title=scenario.behavior.text)


def simulate_scenario(scenario: Scenario) -> SimulationOutput:
    """Write, compile and run the scenario; SimulationError on any simulator failure."""
    from regen.driving.record import build_trace
    from regen.driving.simulate import run_program

    _, plans = plans_for(scenario)
    name = str(scenario.world["map"])
    dt, steps, seed = _timing(scenario)
    run = run_program(scenic_program(scenario), steps=steps, dt=dt, seed=seed)
    t0 = time.perf_counter()
    trace = build_trace(run, plans, geometry(name), map_path=str(ensure_map(name)), seed=seed,
                        meta={"scenario": scenario.id})
    timings = dict(run.timings)
    timings["record"] = time.perf_counter() - t0
    return SimulationOutput(trace=trace, timings=timings)


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


class DrivingBackend(DomainBackend):
    name = "driving"
    database_resource = RESOURCE
    predicates_module = "regen.driving.predicates"
    edge_examples = ("regen.driving", "data/edges_example.jsonl")
    wording = Wording(
        expert="driving scenarios and traffic simulation",
        situation="traffic",
        cause_rule=("Each cause must involve other road users, objects, traffic lights or the ego's "
                    "sensors/driver, not the ego-vehicle's own mechanics."),
        value_hint='relative to the ego-vehicle (lane and side), e.g. "behind the ego-vehicle in the same lane"',
        judge_examples=(
            ("the ego-vehicle swerved to the left", "a parked truck blocked its lane", "yes",
             "it must steer around the truck to pass"),
            ("the ego-vehicle swerved to the left", "a car honked on a street far away", "no",
             "a sound far away gives no reason to swerve"),
            ("the ego-vehicle accelerated", "a child ran onto the road ahead", "no",
             "a child ahead makes it brake, the opposite of accelerating"),
        ),
        # causes that restate the ego's orders, programming or mechanics (rejected after the
        # judge); its camera and GNSS are not here: glare and jamming are simulated contexts
        mechanics=(
            r"(?:\bego(?:[- ](?:vehicle|car))?|\bthe\s+(?:vehicle|car))\s+(?:is|was|gets|got|has\s+been|"
            r"had\s+been)\s+(?:\w+ly\s+|just\s+)?(?:programmed|commanded|instructed|ordered|told|asked|"
            r"scheduled|designed|configured|set|routed|planned)\s+to\b"
            # a police officer's order is a context of the road, not the ego's instructions
            r"(?![^.;]*\bby\s+(?:a|an|the)\s+(?:police|officer|traffic|flagger|road\s+worker|crossing\s+guard))",
            r"\b(?:navigation|gps|route|planner|autopilot|cruise\s+control|software|program)(?:\s+system)?\s+"
            r"(?:tells?|told|instructs?|instructed|commands?|commanded|orders?|ordered|asks?|asked)\b",
            r"\b(?:passenger|operator|dispatcher)s?\b[^.;]*\b(?:asks?|asked|tells?|told|commands?|commanded|"
            r"instructs?|instructed|orders?|ordered|requests?|requested)\b",
            r"\bprograms?\s+(?:the\s+)?ego\b",
            r"(?:\bego(?:[- ](?:vehicle|car))?'s|\bthe\s+(?:vehicle|car)'s|\bthe\s+ego's)\s+(?:own\s+)?(?:\w+\s+)?"
            r"(?:brakes?|braking\s+system|engine|motor|tires?|tyres?|wheels?|steering|transmission|gearbox|"
            r"battery|fuel|gas|accelerator|throttle|suspension|axle|software|firmware|autopilot|"
            r"programming|program|controller|planner|cruise\s+control|computer|mechanics?)\b",
            r"(?:\bego(?:[- ](?:vehicle|car))?|\bthe\s+(?:vehicle|car))\s+(?:just\s+|suddenly\s+)?"
            r"(?:breaks\s+down|broke\s+down|stalls|stalled|malfunctions?|malfunctioned|overheats?|overheated|"
            r"runs\s+out\s+of|ran\s+out\s+of|has\s+(?:a|an)\s+(?:flat|mechanical|technical|engine|brake|software)|"
            r"loses\s+(?:power|its\s+brakes)|is\s+low\s+on\s+(?:fuel|gas|battery))",
            r"(?:\bego(?:[- ](?:vehicle|car))?|\bthe\s+(?:vehicle|car))\s+(?:suffers|has|experiences|develops)\s+"
            r"(?:a|an)\s+(?:sudden\s+)?(?:brake|engine|mechanical|software|steering|technical)\s+"
            r"(?:failure|fault|malfunction|problem)\b",
        ),
    )
    report_hints = ReportHints(animation="bird's-eye animation of the run",
                               keyframes="key frames at the start, at each stage and at the end "
                                         "(click for full size)",
                               robot="ego-vehicle")

    def check_behavior(self, behavior: Behavior) -> None:
        if behavior.reward:
            raise ConfigError("--reward is for manipulation behaviors; driving behaviors take --ego "
                              f"(one of: {', '.join(EGO_TEMPLATES)})")
        template_for(behavior.text, behavior.ego_template)

    def settings_key(self, behavior: Behavior) -> dict[str, str | None]:
        return {"ego_template": template_for(behavior.text, behavior.ego_template).id}

    def property_choices(self, asset: str, behavior: Behavior | None = None
                         ) -> tuple[str | None, dict[str | None, dict[str, list[str]]]] | None:
        """An actor's start locations and speed classes follow its behavior (motion primitive):
        only the starts the primitive supports, and no speed for one that does not move."""
        from regen.driving.primitives import find, is_state_only

        db = self.database()
        if asset not in db.assets or is_state_only(asset) or not db.assets[asset].behaviors:
            return None
        starts = db.property_candidates(asset, "start_location") or []
        speeds = db.property_candidates(asset, "target_speed") or []
        out: dict[str | None, dict[str, list[str]]] = {}
        for b in db.assets[asset].behaviors:
            spec = find(b)
            if spec is None:
                continue
            allowed: dict[str, list[str]] = {}
            if starts:
                allowed["start_location"] = [x for x in spec.starts if x in starts] or list(starts)
            if speeds and spec.moves:
                allowed["target_speed"] = list(speeds)
            out[b] = allowed
        return ("behavior", out) if out else None

    def ground(self, path: CausePath, llm: LLM | None, *, seed: int = 0) -> Scenario:
        """Model grounding when an LLM is given (rules replace what its answers leave unusable,
        recorded in ``scenario.fallbacks``), else the rule-based grounder."""
        if path.behavior.domain != self.name:
            raise GroundingError(f"the driving backend cannot ground a {path.behavior.domain} behavior")
        if llm is not None:
            from regen.driving.llm_ground import ground_with_model

            return ground_with_model(path, llm, seed=seed)
        return ground_rule_based(path, seed=seed)

    def simulate(self, scenario: Scenario, workdir: Path) -> SimulationOutput:
        return simulate_scenario(scenario)

    def render(self, scenario: Scenario, trace: Trace, verdict: Verdict, out_dir: Path) -> dict[str, Path]:
        from regen.driving.render import render_scenario

        return render_scenario(scenario, trace, verdict, out_dir)

    def config(self, scenario: Scenario) -> dict:
        return paper_config(scenario)

    def export(self, scenario: Scenario, out_dir: Path, trace: Trace | None = None) -> dict[str, Path]:
        """The Scenic program that runs the scenario, and with a trace an OpenSCENARIO replay."""
        out_dir = Path(out_dir)
        files: dict[str, Path] = {"scenic": atomic_write_text(out_dir / "scenario.scenic", scenic_program(scenario))}
        if trace is not None:
            from regen.driving.export_xosc import export_openscenario

            files.update(export_openscenario(scenario, trace, out_dir))
        return files


__all__ = ["DrivingBackend", "paper_config", "scenic_program", "simulate_scenario"]
