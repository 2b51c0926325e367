"""Simulation domains behind one small interface, found through a registry (lazy imports).

A domain turns a cause path into a scenario (``ground``), runs it (``simulate``) and draws it
(``render``); verification is shared (:func:`regen.verify.check_fsm`). The core knows no
simulator: each domain lives in its own package and is imported only when asked for, so a
missing optional dependency is reported with its install command, not at import time.
"""

from __future__ import annotations

import importlib
from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, ClassVar

from regen.errors import ConfigError

if TYPE_CHECKING:
    from regen.assets.database import AssetDatabase
    from regen.core.graph import CausePath
    from regen.core.scenario import Scenario
    from regen.core.trace import Trace
    from regen.core.verdict import Verdict
    from regen.llm.client import LLM


@dataclass
class SimulationOutput:
    trace: Trace
    timings: dict[str, float] = field(default_factory=dict)  # stage -> wall seconds
    files: dict[str, Path] = field(default_factory=dict)  # artifact name -> path (e.g. .scenic)


class DomainBackend(ABC):
    """What a simulation domain provides to the pipeline."""

    name: ClassVar[str]

    @abstractmethod
    def database(self) -> AssetDatabase:
        """The asset database of this domain's simulator."""

    @abstractmethod
    def ground(self, path: CausePath, llm: LLM, *, seed: int = 0) -> Scenario:
        """Turn a cause path into a scenario with an FSM and solved parameters.

        An unsatisfiable scenario is returned with ``solver.status == 'infeasible'`` and the
        conflicts named; it is not an exception.
        """

    @abstractmethod
    def simulate(self, scenario: Scenario, workdir: Path) -> SimulationOutput:
        """Run the scenario; raise :class:`regen.errors.SimulationError` on simulator failure."""

    @abstractmethod
    def render(self, scenario: Scenario, trace: Trace, verdict: Verdict, out_dir: Path) -> dict[str, Path]:
        """Pictures (GIF, PNG strip) of the run, written into ``out_dir``."""

    def export(self, scenario: Scenario, out_dir: Path, trace: Trace | None = None) -> dict[str, Path]:
        """Files other simulators load (Scenic, OpenSCENARIO, ...), given the run's trace when
        there is one. Optional."""
        return {}

    def config(self, scenario: Scenario) -> dict:
        """The scenario in the paper's config form (narrative, entities, vehicles, fsm)."""
        return {"narrative": scenario.narrative, "causal_graph": scenario.causal_graph,
                "fsm": scenario.fsm.as_tuples()}


_REGISTRY: dict[str, str] = {
    "driving": "regen.driving.backend:DrivingBackend",
    "manipulation": "regen.manipulation.backend:ManipulationBackend",
}


def register(name: str, entry_point: str) -> None:
    """Register a domain backend as ``'package.module:Class'`` (imported on first use)."""
    _REGISTRY[name] = entry_point


def make(name: str) -> DomainBackend:
    if name not in _REGISTRY:
        raise ConfigError(f"unknown domain {name!r}; choose one of: {', '.join(sorted(_REGISTRY))}")
    module, _, cls = _REGISTRY[name].partition(":")
    return getattr(importlib.import_module(module), cls)()
