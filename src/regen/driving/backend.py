"""The driving domain behind :class:`regen.domains.DomainBackend`.

``ground`` -> Scenario, ``simulate`` -> Trace (Scenic Newtonian), ``verify`` (FSM monitor with
the relaxation of over-strict stages), ``render`` (if :mod:`regen.driving.render` exists) and
``export`` (paper-style scenario.json and the .scenic file). :func:`run_path` runs one cause
path end to end and turns every failure into a recorded verdict.
"""

from __future__ import annotations

import importlib
import logging
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from regen.assets.database import AssetDatabase, load_database
from regen.core.graph import CausePath
from regen.core.io import atomic_write_text, write_json
from regen.core.scenario import FSM, Scenario, Stage
from regen.core.trace import Trace
from regen.core.verdict import Verdict
from regen.domains import DomainBackend, SimulationOutput
from regen.driving.ground import ground_rule_based, plans_for
from regen.driving.maps import ensure_map, geometry
from regen.driving.scenic_writer import write_program
from regen.errors import GroundingError, RegenError, SimulationError
from regen.verify.monitor import check_fsm, validate_fsm

if TYPE_CHECKING:
    from regen.llm.client import LLM

log = logging.getLogger(__name__)


def scenic_program(scenario: Scenario) -> str:
    """The Scenic program of a grounded scenario (the map is generated if needed)."""
    _, plans = plans_for(scenario)
    dt = float(scenario.world.get("dt", 0.1))
    steps = int(round(float(scenario.world.get("duration", 16.0)) / dt))
    return write_program(plans, map_path=str(ensure_map(str(scenario.world["map"]))), dt=dt,
                         max_steps=steps, narrative=scenario.narrative,
                         seed=int(scenario.world.get("seed", 0)), title=scenario.behavior.text)


def simulate_scenario(scenario: Scenario) -> SimulationOutput:
    """Write, compile and run the scenario; SimulationError on any simulator failure."""
    from regen.driving.record import build_trace
    from regen.driving.simulate import run_program

    _, plans = plans_for(scenario)
    name = str(scenario.world["map"])
    map_path = ensure_map(name)
    dt = float(scenario.world.get("dt", 0.1))
    steps = int(round(float(scenario.world.get("duration", 16.0)) / dt))
    seed = int(scenario.world.get("seed", 0))
    text = write_program(plans, map_path=str(map_path), dt=dt, max_steps=steps,
                         narrative=scenario.narrative, seed=seed, title=scenario.behavior.text)
    run = run_program(text, steps=steps, dt=dt, seed=seed)
    t0 = time.perf_counter()
    trace = build_trace(run, plans, geometry(name), map_path=str(map_path), seed=seed,
                        meta={"scenario": scenario.id})
    timings = dict(run.timings)
    timings["record"] = time.perf_counter() - t0
    return SimulationOutput(trace=trace, timings=timings)


def relax_fsm(fsm: FSM, verdict: Verdict) -> tuple[FSM, str] | None:
    """Split the first unmet stage into consecutive stages, ordered by when each condition first
    held on its own, when every condition held at some time but never all at once."""
    k = verdict.first_unmet_stage
    if k is None or verdict.status != "fsm_incomplete":
        return None
    stage = verdict.stages[k - 1]
    alone = stage.satisfied_alone
    if len(alone) < 2 or any(t is None for t in alone.values()):
        return None
    conds = fsm.stages[k - 1].conditions
    labels = [f"{c.actor}: {c.state}" for c in conds]
    order = sorted(range(len(conds)), key=lambda i: (alone[labels[i]], i))
    new = [Stage(conditions=[conds[i]]) for i in order]
    stages = fsm.stages[: k - 1] + new + fsm.stages[k:]
    note = (f"stage {k} ({'; '.join(labels)}) required its conditions at the same instant; "
            f"relaxed into {len(new)} consecutive stages: " + " -> ".join(labels[i] for i in order))
    return FSM(states=fsm.states, stages=stages), note


def verify(scenario: Scenario, trace: Trace, *, max_relaxations: int = 3) -> tuple[Verdict, Scenario]:
    """The FSM verdict; over-strict stages are relaxed (and recorded) up to a cap."""
    verdict = check_fsm(scenario, trace)
    for _ in range(max_relaxations):
        if verdict.feasible:
            break
        relaxed = relax_fsm(scenario.fsm, verdict)
        if relaxed is None:
            break
        fsm, note = relaxed
        log.info("relaxing FSM of %s: %s", scenario.id, note)
        solver = scenario.solver.model_copy(update={"relaxations": scenario.solver.relaxations + [note]})
        scenario = scenario.model_copy(update={"fsm": fsm, "solver": solver})
        verdict = check_fsm(scenario, trace)
    return verdict, scenario


@dataclass
class PathResult:
    """Everything one cause path produced (some fields empty when a step failed)."""

    verdict: Verdict
    scenario: Scenario | None = None
    trace: Trace | None = None
    timings: dict[str, float] = field(default_factory=dict)
    files: dict[str, Path] = field(default_factory=dict)


def _failed(status: str, reason: str, scenario: Scenario | None = None, **kw) -> PathResult:
    return PathResult(Verdict(feasible=False, status=status, reason=reason,  # type: ignore[arg-type]
                              conflicts=list(scenario.solver.conflicts) if scenario else []),
                      scenario, **kw)


def run_path(path: CausePath, *, llm: LLM | None = None, seed: int = 0,
             out_dir: Path | None = None) -> PathResult:
    """Ground, simulate and verify one cause path; every failure is a recorded verdict."""
    backend = DrivingBackend()
    timings: dict[str, float] = {}
    t0 = time.perf_counter()
    try:
        scenario = backend.ground(path, llm, seed=seed)
    except RegenError as exc:
        return _failed("grounding_failed", str(exc))
    timings["ground"] = time.perf_counter() - t0
    timings["solve"] = scenario.solver.wall_time
    result = _checked_run(backend, scenario, timings)
    if out_dir is not None:
        result.files = write_outputs(result, Path(out_dir))
    return result


def _checked_run(backend: DrivingBackend, scenario: Scenario, timings: dict[str, float]) -> PathResult:
    if scenario.solver.status == "infeasible":
        reason = "the placement constraints cannot all hold: " + "; ".join(scenario.solver.conflicts)
        return PathResult(Verdict(feasible=False, status="unsatisfiable", reason=reason,
                                  conflicts=list(scenario.solver.conflicts)), scenario, timings=timings)
    if scenario.solver.status not in ("optimal", "feasible"):
        return _failed("unsatisfiable", f"the solver found no placement ({scenario.solver.status})",
                       scenario, timings=timings)
    problems = validate_fsm(scenario.fsm, {e.name for e in scenario.entities}, "driving")
    if problems:
        return _failed("invalid_scenario", "; ".join(problems), scenario, timings=timings)
    try:
        out = backend.simulate(scenario, Path("."))
    except (SimulationError, RegenError) as exc:
        return _failed("simulation_failed", str(exc), scenario, timings=timings)
    timings.update(out.timings)
    t0 = time.perf_counter()
    verdict, scenario = verify(scenario, out.trace)
    timings["verify"] = time.perf_counter() - t0
    return PathResult(verdict, scenario, out.trace, timings)


def write_outputs(result: PathResult, out_dir: Path) -> dict[str, Path]:
    """scenario.json, scenario.scenic, trace.json and verdict.json, each written atomically."""
    files: dict[str, Path] = {}
    out_dir.mkdir(parents=True, exist_ok=True)
    if result.scenario is not None:
        backend = DrivingBackend()
        files["scenario"] = write_json(out_dir / "scenario.json", {
            "scenario": result.scenario.model_dump(mode="json"), "config": paper_config(result.scenario)})
        files.update(backend.export(result.scenario, out_dir, trace=result.trace))
    if result.trace is not None:
        files["trace"] = write_json(out_dir / "trace.json", result.trace)
    files["verdict"] = write_json(out_dir / "verdict.json", result.verdict)
    return files


def paper_config(scenario: Scenario) -> dict:
    """The paper's 'Full Config Example' form of a scenario (appendix), plus the FSM states."""
    _, plans = plans_for(scenario)
    by = {p.name: p for p in plans}
    vehicles = []
    db = load_database("driving")
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

    def database(self) -> AssetDatabase:
        return load_database("driving")

    def ground(self, path: CausePath, llm: LLM | None, *, seed: int = 0) -> Scenario:
        """Model grounding when an LLM is given (falling back to rules when its FSM is
        unusable), else the rule-based grounder."""
        if path.behavior.domain != "driving":
            raise GroundingError(f"the driving backend cannot ground a {path.behavior.domain} behavior")
        if llm is not None:
            try:
                from regen.driving.llm_ground import ground_with_model
            except ImportError as exc:  # the LLM layer is not installed in this build
                log.warning("model grounding unavailable (%s); using rules", exc)
            else:
                return ground_with_model(path, llm, seed=seed)
        return ground_rule_based(path, seed=seed)

    def simulate(self, scenario: Scenario, workdir: Path) -> SimulationOutput:
        return simulate_scenario(scenario)

    def render(self, scenario: Scenario, trace: Trace, verdict: Verdict, out_dir: Path) -> dict[str, Path]:
        try:
            module = importlib.import_module("regen.driving.render")
        except ModuleNotFoundError as exc:
            if exc.name != "regen.driving.render":
                raise
            return {}
        return module.render_scenario(scenario, trace, verdict, out_dir)

    def config(self, scenario: Scenario) -> dict:
        return paper_config(scenario)

    def export(self, scenario: Scenario, out_dir: Path, trace: Trace | None = None) -> dict[str, Path]:
        """The Scenic program that runs the scenario, and with a trace an OpenSCENARIO replay."""
        out_dir = Path(out_dir)
        files: dict[str, Path] = {}
        try:
            files["scenic"] = atomic_write_text(out_dir / "scenario.scenic", scenic_program(scenario))
        except RegenError as exc:
            log.warning("no Scenic file for %s: %s", scenario.id, exc)
        if trace is not None:
            from regen.driving.export_xosc import export_openscenario

            files.update(export_openscenario(scenario, trace, out_dir))
        return files


__all__ = ["DrivingBackend", "PathResult", "paper_config", "relax_fsm", "run_path",
           "scenic_program", "simulate_scenario", "verify", "write_outputs"]
