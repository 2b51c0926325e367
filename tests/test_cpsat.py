"""regen.cpsat: named constraints, one solve, a minimal conflict set when infeasible."""

from __future__ import annotations

import pytest

pytest.importorskip("ortools")

from regen.cpsat import NamedModel, make_solver  # noqa: E402


def _model() -> tuple[NamedModel, object, object]:
    M = NamedModel()
    x = M.m.NewIntVar(0, 100, "x")
    y = M.m.NewIntVar(0, 100, "y")
    return M, x, y


def _feasible_with(M: NamedModel, names: list[str]) -> bool:
    """Is the model feasible with only the constraints ``names`` enforced?"""
    M.m.ClearAssumptions()
    M.m.AddAssumptions([M.lits[n] for n in names])
    return make_solver(1.0).Solve(M.m) in (M.cp.OPTIMAL, M.cp.FEASIBLE)


def test_feasible_model_is_solved_with_every_constraint():
    M, x, y = _model()
    M.require("x at least 10", x >= 10)
    M.require("y above x", y >= x + 5)
    M.m.Minimize(y)
    out = M.solve(1.0)
    assert out.status == "optimal" and out.solved
    assert (out.value(x), out.value(y)) == (10, 15)
    assert out.conflicts == []


def test_infeasible_model_names_a_minimal_conflict_set():
    M, x, y = _model()
    M.require("x at least 60", x >= 60)
    M.require("y at least 10", y >= 10)  # takes part in no conflict
    M.require("x plus y at most 50", x + y <= 50)
    M.require("x at most 40", x <= 40)
    out = M.solve(1.0)
    assert out.status == "infeasible" and not out.solved
    # {x >= 60, x <= 40} conflicts alone; so does {x >= 60, x + y <= 50}: deletion keeps one
    # set in which every name is needed
    assert out.conflicts in (["x at least 60", "x at most 40"], ["x at least 60", "x plus y at most 50"])
    assert not _feasible_with(M, out.conflicts)
    for name in out.conflicts:  # dropping any one name leaves a feasible model
        assert _feasible_with(M, [n for n in out.conflicts if n != name])


def test_repeated_names_are_numbered():
    M, x, _ = _model()
    M.require("x small", x <= 5)
    M.require("x small", x <= 3)
    assert list(M.lits) == ["x small", "x small (2)"]


def test_the_limit_is_the_solvers_own_work_so_a_busy_machine_decides_the_same():
    # a wall-clock limit made the start places offered to the graph depend on the machine's load
    # (a probe that ran out of time on a busy machine dropped its place); the wall clock is only
    # a safety net
    solver = make_solver(0.5)
    assert solver.parameters.max_deterministic_time == 0.5
    assert solver.parameters.max_time_in_seconds >= 10 * 0.5


def test_models_carry_ortools_own_old_names_once_on_the_class():
    from regen.cpsat import cp_model, model_class

    ours, theirs = model_class()(), cp_model().CpModel()
    old = sorted(n for n in vars(theirs) if n[:1].isupper())  # what ortools sets on each model
    assert old and not [n for n in vars(ours) if n[:1].isupper()]  # none per model here
    for m in (ours, theirs):  # the same model through those names, proto for proto
        x, y = m.NewIntVar(0, 10, "x"), m.NewIntVar(0, 10, "y")
        b = m.NewBoolVar("b")
        m.Add(x + y >= 7).OnlyEnforceIf(b)
        m.AddBoolOr([b])
        m.AddAbsEquality(m.NewIntVar(0, 10, "d"), x - 5)
        m.Minimize(y)
    assert str(ours.proto) == str(theirs.proto) and "constraints" in str(ours.proto)
    assert all(callable(getattr(ours, n)) for n in old)


def test_a_caller_that_reads_only_the_status_skips_the_minimal_set(monkeypatch):
    M, x, y = _model()
    M.require("x at least 60", x >= 60)
    M.require("y at least 60", y >= 60)
    M.require("x plus y at most 100", x + y <= 100)
    M.require("x at least 1", x >= 1)

    def no_minimising(*_a, **_k):
        raise AssertionError("minimised for a caller that did not ask")

    monkeypatch.setattr(NamedModel, "minimise", no_minimising)
    out = M.solve(1.0, explain=False)
    assert out.status == "infeasible" and set(out.conflicts) >= {"x at least 60", "y at least 60",
                                                                  "x plus y at most 100"}
