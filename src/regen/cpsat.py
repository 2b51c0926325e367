"""One way to make a CP-SAT solver, for every domain's placement model.

``catch_sigint_signal`` is off: CP-SAT's own SIGINT handler would otherwise replace Python's and
leave the default action behind after the solve, so a later Ctrl-C killed the run without the
clean "interrupted" stop (and without saving its state). One worker, so that the sufficient
assumptions of an infeasible model form a small core that names the conflicting constraints.
"""

from __future__ import annotations

from typing import Any


def make_solver(time_limit: float, *, seed: int = 0) -> Any:
    """A CP-SAT solver limited to ``time_limit`` [s] of wall time, deterministic for ``seed``."""
    from ortools.sat.python import cp_model

    solver = cp_model.CpSolver()
    solver.parameters.max_time_in_seconds = time_limit
    solver.parameters.num_workers = 1
    solver.parameters.random_seed = seed
    solver.parameters.catch_sigint_signal = False
    return solver
