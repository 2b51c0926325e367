"""Scenic's stuck-behavior alarm stays off while regen simulates: no SIGALRM is armed per
behavior step (it cost 5% of a scenario's simulation and causal check), and Scenic's setting is
as it was afterwards, for anyone else in the process."""

from __future__ import annotations

import signal

import pytest
from driving_chains import FEASIBLE  # noqa: E402

from regen.driving.grounding.rules import ground_rule_based  # noqa: E402
from regen.driving.simulation.run import run_program  # noqa: E402
from regen.driving.simulation.scenario import scenic_program  # noqa: E402
from regen.driving.testing.loop import run_policy  # noqa: E402
from regen.driving.testing.reference import ReferenceDriver  # noqa: E402

pytest.importorskip("scenic")
from scenic.core import dynamics  # noqa: E402


@pytest.fixture
def alarms(monkeypatch):
    """The SIGALRM handlers installed while the test runs."""
    armed: list[object] = []
    real = signal.signal

    def counting(signum, handler):
        if signum == signal.SIGALRM:
            armed.append(handler)
        return real(signum, handler)

    monkeypatch.setattr(signal, "signal", counting)
    return armed


@pytest.fixture(scope="module")
def scenario():
    return ground_rule_based(FEASIBLE["stop_abruptly"][2], seed=0)


def test_a_scenario_run_arms_no_alarm_and_restores_scenics_setting(alarms, scenario) -> None:
    before = dynamics.stuckBehaviorWarningTimeout
    run = run_program(scenic_program(scenario), steps=30, dt=0.1)
    assert len(run.times) >= 30  # the behaviors did step
    assert alarms == []
    assert dynamics.stuckBehaviorWarningTimeout == before > 0


def test_a_reference_driver_run_arms_no_alarm(alarms, scenario) -> None:
    before = dynamics.stuckBehaviorWarningTimeout
    ep = run_policy(scenario, ReferenceDriver(), step_timeout=None, steps=30)
    assert ep.trace is not None and len(ep.trace.times) >= 30
    assert alarms == []
    assert dynamics.stuckBehaviorWarningTimeout == before > 0


def test_scenic_arms_its_alarm_each_step_outside_regens_runs(alarms, scenario) -> None:
    """What the two tests above rule out, shown on Scenic itself: without regen's block, each
    behavior step installs a SIGALRM handler (so the counting above can see one)."""
    from regen.driving.simulation import run as sim_run

    text = scenic_program(scenario)
    compiled = sim_run.compile_program(text)
    scene, _ = compiled.generate(maxIterations=1, verbosity=0)
    _, newtonian = sim_run.scenic_modules()
    newtonian.NewtonianSimulator().simulate(scene, maxSteps=10, timestep=0.1, verbosity=0)
    assert len(alarms) >= 10
