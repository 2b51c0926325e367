"""The manipulation domain behind :class:`regen.domains.DomainBackend` (PyBullet)."""

from __future__ import annotations

from pathlib import Path

from regen.assets.database import AssetDatabase, load_database
from regen.core.graph import CausePath
from regen.core.scenario import Scenario
from regen.core.trace import Trace
from regen.core.verdict import Verdict
from regen.domains import DomainBackend, SimulationOutput
from regen.errors import SimulationError


class ManipulationBackend(DomainBackend):
    """Ground with CP-SAT placement, simulate in PyBullet with the scripted controller."""

    name = "manipulation"

    def database(self) -> AssetDatabase:
        return load_database("manipulation")

    def ground(self, path: CausePath, llm, *, seed: int = 0) -> Scenario:
        from regen.manipulation.grounding import ground_path

        return ground_path(path, llm, seed=seed)

    def simulate(self, scenario: Scenario, workdir: Path) -> SimulationOutput:
        from regen.manipulation.simulate import rollout

        if scenario.solver.status == "infeasible":
            raise SimulationError("the scenario's placement is infeasible: "
                                  + "; ".join(scenario.solver.conflicts))
        result = rollout(scenario)
        timings = dict(result.timings)
        timings["placement"] = scenario.solver.wall_time
        return SimulationOutput(trace=result.trace, timings=timings)

    def render(self, scenario: Scenario, trace: Trace, verdict: Verdict, out_dir: Path) -> dict[str, Path]:
        from regen.manipulation.render import render_run

        return render_run(scenario, trace, verdict, out_dir)
