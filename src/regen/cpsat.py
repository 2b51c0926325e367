"""CP-SAT for every domain's placement model: named constraints, one solve, minimal conflicts.

A :class:`NamedModel` holds a CP-SAT model whose constraints a user would recognise each have
a name and an enforcement literal; :meth:`NamedModel.solve` assumes all those literals. When
the model is infeasible, the solver's sufficient assumptions are cut down by deletion (drop one
name, keep the rest assumed: still infeasible, so it was not needed) to a minimal conflict set:
every name left is needed, and removing any one of them makes the model feasible.

``catch_sigint_signal`` is off: CP-SAT's own SIGINT handler would otherwise replace Python's and
leave the default action behind after the solve, so a later Ctrl-C killed the run without the
clean "interrupted" stop (and without saving its state). One worker, so that the sufficient
assumptions of an infeasible model form a small core that names the conflicting constraints,
and so that the same seed gives the same solution.
"""

from __future__ import annotations

import functools
import time
from dataclasses import dataclass, field
from typing import Any

from regen.errors import DependencyNotInstalled

STATUS = {"OPTIMAL": "optimal", "FEASIBLE": "feasible", "INFEASIBLE": "infeasible",
          "MODEL_INVALID": "model_invalid"}  # CP-SAT status -> ours ('unknown' otherwise)


def cp_model() -> Any:
    """The ``ortools.sat.python.cp_model`` module."""
    try:
        from ortools.sat.python import cp_model as cp
    except ModuleNotFoundError as exc:  # ortools is a core dependency; be explicit anyway
        raise DependencyNotInstalled("ortools", "all", "solving placements") from exc
    return cp


@functools.cache
def model_class() -> type:
    """``CpModel`` with its pre-PEP 8 names (``NewIntVar``, ``Add``, ``Minimize``, ...) defined
    once on the class. ortools sets them on every model it makes (``_add_pre_pep8_methods``:
    0.4 ms, a third of the time to build a placement probe, and expansion builds hundreds);
    here they are the very methods, without the per-model copies."""
    cp = cp_model()
    base = cp.CpModel
    probe = base()  # what ortools adds to an instance: exactly those names, nothing else
    added = {name for name in vars(probe) if name[:1].isupper()}
    snake = {cp.snake_case_to_camel_case(n): n for n in dir(base) if not n.startswith("_")}
    names = {camel: getattr(base, snake[camel]) for camel in added if camel in snake}
    missing = added - names.keys()
    if missing:  # an ortools whose aliases this does not know: keep its own way
        return base
    return type("RegenCpModel", (base,), {"_add_pre_pep8_methods": lambda self: None, **names})


#: Wall time a solve may take, as a multiple of its limit: only a safety net. The limit itself is
#: CP-SAT's deterministic time (its own work count, about seconds of one core), so a machine
#: busy with other work finds the same answers, only later.
WALL_TIME_FACTOR = 20.0


def make_solver(time_limit: float, *, seed: int = 0) -> Any:
    """A CP-SAT solver limited to ``time_limit`` of deterministic time (CP-SAT's measure of its
    work, about seconds of one core), so the outcome is the same on a loaded machine, and to
    ``WALL_TIME_FACTOR`` times that of wall time; deterministic for ``seed``."""
    solver = cp_model().CpSolver()
    solver.parameters.max_deterministic_time = time_limit
    solver.parameters.max_time_in_seconds = WALL_TIME_FACTOR * time_limit
    solver.parameters.num_workers = 1
    solver.parameters.random_seed = seed
    solver.parameters.catch_sigint_signal = False
    return solver


@dataclass
class Outcome:
    """What one :meth:`NamedModel.solve` found."""

    status: str  # 'optimal', 'feasible', 'infeasible', 'model_invalid' or 'unknown'
    solver: Any  # the CP-SAT solver after the solve (its ``Value`` reads a solution)
    conflicts: list[str] = field(default_factory=list)  # a minimal conflict set when infeasible
    wall_time: float = 0.0  # [s], minimisation included

    @property
    def solved(self) -> bool:
        return self.status in ("optimal", "feasible")

    def value(self, var: Any) -> int:
        """A variable's value in the solution."""
        return self.solver.Value(var)

    @property
    def cp_status(self) -> str:
        """CP-SAT's own name of the status (e.g. 'UNKNOWN' when the time ran out)."""
        return self.solver.StatusName()


class NamedModel:
    """A CP-SAT model (``m``) whose named constraints are each enforced through an assumption
    literal (``lits``: name -> literal, in the order they were named)."""

    def __init__(self) -> None:
        self.cp = cp_model()
        self.m = model_class()()
        self.lits: dict[str, Any] = {}

    def literal(self, name: str) -> Any:
        """A new literal that stands for the constraint ``name`` (numbered when the name repeats);
        everything added with ``.OnlyEnforceIf(literal)`` is that one named constraint."""
        lit = self.m.NewBoolVar(name)
        key, i = name, 2
        while key in self.lits:
            key = f"{name} ({i})"
            i += 1
        self.lits[key] = lit
        return lit

    def require(self, name: str, expr: Any) -> Any:
        """Add ``expr`` as the constraint ``name``; its literal."""
        lit = self.literal(name)
        self.m.Add(expr).OnlyEnforceIf(lit)
        return lit

    def solve(self, time_limit: float, *, seed: int = 0, explain: bool = True) -> Outcome:
        """Solve with every named constraint assumed (``time_limit`` [s] of solver work); when infeasible, the
        outcome's ``conflicts`` are a minimal conflict set (empty when the constraints nobody
        named conflict on their own), or with ``explain=False`` (a caller that reads only the
        status) the solver's own, not minimised: minimising takes a solve per name."""
        t0 = time.perf_counter()
        self.m.ClearAssumptions()
        self.m.AddAssumptions(list(self.lits.values()))
        solver = make_solver(time_limit, seed=seed)
        out = Outcome(STATUS.get(solver.StatusName(solver.Solve(self.m)), "unknown"), solver)
        if out.status == "infeasible":
            by_index = {lit.Index(): name for name, lit in self.lits.items()}
            core = [by_index[i] for i in solver.SufficientAssumptionsForInfeasibility() if i in by_index]
            out.conflicts = self.minimise(core, time_limit / 4) if explain else core
        out.wall_time = time.perf_counter() - t0
        return out

    def minimise(self, names: list[str], time_limit: float) -> list[str]:
        """Deletion filter: drop each name of an infeasible set whose rest stays infeasible
        (each trial solve at most ``time_limit`` [s] of solver work; one that runs out keeps its name)."""
        trial_model = self.m.clone()
        trial_model.clear_objective()  # feasibility is all a trial asks
        keep = list(names)
        for name in names:
            trial = [n for n in keep if n != name]
            if not trial:
                continue
            trial_model.ClearAssumptions()
            trial_model.AddAssumptions([self.lits[n] for n in trial])
            if make_solver(time_limit).Solve(trial_model) == self.cp.INFEASIBLE:
                keep = trial
        return keep


__all__ = ["STATUS", "NamedModel", "Outcome", "cp_model", "make_solver", "model_class"]
