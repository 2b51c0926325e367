"""The driving domain's policy harness: a driving policy in place of the scripted ego.

The policy sees an :class:`~regen.driving.testing.policies.Observation` at the scenario's step
(10 Hz) and returns an :class:`~regen.driving.testing.policies.Action` (acceleration [m/s^2],
curvature [1/m]); the other actors' cause actions start on triggers relative to the ego
(:mod:`regen.driving.world.triggers`), so the cause meets whatever ego drives. Incidents are
the ego's collisions and infractions (running a red light, leaving the road) from
:mod:`regen.driving.verify.collisions`; the oracle asks for the ego's FSM states with the
template's manner dropped (:data:`MANNER`).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from regen.core.scenario import AbstractState, Scenario
from regen.core.trace import Trace
from regen.driving.testing import loop, policies, variants
from regen.driving.testing.reference import ReferenceDriver
from regen.driving.verify.collisions import SafetyReport, analyze
from regen.harness.contract import Episode, Incident, PolicyHarness, TemplateRun, wire_numbers

EGO = "ego"

#: the policies ``regen test`` knows by name: the built-in ones and the reference driver (which,
#: without the road's lanes that no policy observes, never changes lane)
BUILTIN = {**policies.BUILTIN, "reference": ReferenceDriver}


def load_policy(spec: str) -> policies.Policy:
    """:func:`regen.driving.testing.policies.load_policy`, with the reference driver by name too."""
    from regen.harness.loading import load_callable

    return load_callable(spec, BUILTIN)

# How hard the template ego brakes or accelerates is its manner, not the behavior under test: a
# policy that brakes earlier and more gently still stops for the cause. The oracle replaces these
# thresholds [m/s^2] with ones that only ask for the motion itself.
MANNER = {"braking": {"min_decel": 0.5}, "accelerating": {"min_accel": 0.3}}


class DrivingHarness(PolicyHarness):
    robot = "ego"
    builtin = {
        "idm": "Intelligent Driver Model behind the nearest actor in the ego's path; stops for red "
               "lights and closing sirens",
        "constant-speed": "holds the route's cruise speed and ignores everyone",
        "aeb": "cruises, brakes fully when the time to collision drops under 1.5 s",
        "reference": "the careful driver of the but-for check (IDM, lights, yielding, sirens, checkpoints, "
                     "hazards); here without lane changes",
    }
    step_timeout = loop.STEP_TIMEOUT
    parameter_units = {"s": "m", "v": "m/s", "t": "s", "d0": "m"}

    def __init__(self) -> None:
        self._last: tuple[int, SafetyReport] | None = None  # judge asks twice of one trace
        # a parameter search asks for many variants of one scenario: its feasible set is built once
        self._feasible: tuple[str, variants.FeasibleSet | None] | None = None

    def _analysis(self, trace: Trace) -> SafetyReport:
        if self._last is None or self._last[0] != id(trace):
            self._last = (id(trace), analyze(trace, ego=EGO))
        return self._last[1]

    # the contract's policy loading and episodes are this domain's own functions
    load_policy = staticmethod(load_policy)
    prepare = staticmethod(loop.prepare)
    run_policy = staticmethod(loop.run_policy)

    def action_to_wire(self, action: Any) -> list[float]:
        a = policies.as_action(action)
        return [a.acceleration, a.curvature]

    def action_from_wire(self, data: Any) -> policies.Action:
        return policies.Action(*wire_numbers(data, (2,)))

    def incidents(self, scenario: Scenario, trace: Trace) -> list[Incident]:
        return [Incident(kind=e.kind, t=e.t, step=e.step, actors=tuple(e.actors), message=e.describe(),
                         collision=e.kind == "collision")
                for e in self._analysis(trace).events if EGO in e.actors]

    def excused(self, scenario: Scenario, template_trace: Trace) -> set[str]:
        """Every kind of event in the template ego's run, whoever committed it (a red-light
        runner's scenario excuses the ego's red light as the template's run has one)."""
        return {e.kind for e in self._analysis(template_trace).events}

    def metrics(self, scenario: Scenario, trace: Trace) -> dict[str, float | None]:
        """``min_ttc`` [s] and ``min_distance`` [m] of the ego (inf: never approached)."""
        rep = self._analysis(trace)
        return {"min_ttc": rep.min_ttc(EGO), "min_distance": rep.min_distance(EGO)}

    def oracle_state(self, scenario: Scenario, state: AbstractState) -> AbstractState:
        calls = [c.model_copy(update={"params": {**c.params, **MANNER[c.name]}}) if c.name in MANNER else c
                 for c in state.all_of]
        return state.model_copy(update={"all_of": calls})

    def sample_variants(self, scenario: Scenario, n: int, seed: int, *, extremes: bool = False
                        ) -> list[Scenario]:
        return variants.sample_variants(scenario, n, seed, extremes=extremes)

    def check_template(self, scenario: Scenario) -> TemplateRun:
        return variants.check_template(scenario)

    def _feasible_set(self, scenario: Scenario) -> variants.FeasibleSet | None:
        # the placement model depends on everything but the solved parameters
        key = scenario.model_dump_json(exclude={"parameters", "solver"})
        if self._feasible is None or self._feasible[0] != key:
            self._feasible = (key, variants.feasible_set(scenario))
        return self._feasible[1]

    def parameter_keys(self, scenario: Scenario) -> list[tuple[str, str]]:
        """Every actor's solved ``s``, ``v``, ``t``, ``d0`` whose feasible range is not a single
        value (:func:`regen.driving.testing.variants.free_parameters`); none when the rebuilt
        placement model is infeasible."""
        fs = self._feasible_set(scenario)
        return [] if fs is None else variants.free_parameters(fs)

    def variant_near(self, scenario: Scenario, targets: Mapping[tuple[str, str], float], seed: int
                     ) -> Scenario | None:
        """:func:`regen.driving.testing.variants.variant_near`: a target 0 is the parameter's
        lowest feasible value, 1 its highest."""
        fs = self._feasible_set(scenario)
        return None if fs is None else variants.variant_near(scenario, dict(targets), seed, fs=fs)

    def failure_picture(self, scenario: Scenario, episode: Episode, prepared: Any, case: Any,
                        policy: str, out: Path) -> Path | None:
        from regen.driving.testing.failure_pictures import render_failure

        if episode.trace is None:
            return None
        return render_failure(scenario, episode.trace, case, Path(out).parent, policy=policy)


__all__ = ["BUILTIN", "EGO", "MANNER", "DrivingHarness", "load_policy"]
