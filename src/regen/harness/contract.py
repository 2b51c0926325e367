"""What a domain provides so that ``regen test`` can run a user's policy in its scenarios.

A domain's backend returns a :class:`PolicyHarness` from
:meth:`regen.contract.DomainBackend.policy_harness` (None: the domain tests no policies). The
shared code (:mod:`regen.harness`) runs the suite, judges each episode with the FSM oracle on the
robot's states plus the domain's :class:`Incident` list, and writes ``tests.json``, ``junit.xml``
and failure pictures; it never names a domain, and the words it prints come from the harness
(:attr:`PolicyHarness.robot`).

The harness owns the simulator side: how a policy replaces the robot in a scenario
(:meth:`prepare`, :meth:`run_policy`), its observation and action types (documented by the
built-in policies), what counts as a failure besides the FSM (:meth:`incidents`: collisions,
infractions, displaced objects, a time budget), the feasible set its variants are drawn from
(:meth:`sample_variants`) and how the scripted robot fares in a variant (:meth:`check_template`);
optionally, the feasible point nearest to given targets (:meth:`parameter_keys`,
:meth:`variant_near`), which ``regen falsify``'s parameter search asks for.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar

if TYPE_CHECKING:
    from regen.core.scenario import AbstractState, Scenario, StateRef
    from regen.core.trace import Trace
    from regen.core.verdict import Verdict

Policy = Callable[[Any], Any]  # observation -> action, in the domain's types


@dataclass
class Episode:
    """One run of a policy in a scenario (the simulator's side of a test case)."""

    trace: Trace | None  # up to the step where it ended; None when nothing ran
    failure: str | None = None  # why the policy failed, in words
    failure_kind: str | None = None  # 'exception', 'invalid_action', 'timeout'
    failure_time: float | None = None  # [s]
    steps: int = 0  # physics steps simulated
    timings: dict[str, float] = field(default_factory=dict)  # stage -> wall seconds


@dataclass(frozen=True)
class Incident:
    """A failure the FSM does not express: a collision, an infraction, a displaced object, a
    time budget overrun. ``collision`` incidents end the robot's stage check at ``step``."""

    kind: str  # e.g. 'collision', 'red_light', 'off_road', 'displaced', 'time_budget'
    t: float  # [s] when it happened
    step: int  # trace index
    actors: tuple[str, ...]  # who took part, the robot first when it did
    message: str  # one line, in the domain's words
    collision: bool = False


@dataclass
class TemplateRun:
    """The scripted robot in one scenario variant: a variant tests a policy only when the
    scripted robot verifies in it (and, in an adversarial search, collides with nothing)."""

    verdict: Verdict | None  # None: the simulation failed
    trace: Trace | None = None
    judged: Scenario | None = None  # the scenario whose FSM the verdict is about (relaxed or not)
    collisions: list[str] = field(default_factory=list)  # the scripted robot's collisions, in words
    error: str = ""


def wire_numbers(data: Any, sizes: tuple[int, ...]) -> list[float]:
    """``data`` from a policy's process as a list of finite floats of one of ``sizes``;
    ValueError otherwise (what :meth:`PolicyHarness.action_from_wire` checks first)."""
    if not isinstance(data, list) or len(data) not in sizes:
        raise ValueError(f"expected {' or '.join(map(str, sizes))} numbers, got {str(data)[:80]}")
    if not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in data):
        raise ValueError(f"expected numbers, got {str(data)[:80]}")
    out = [float(v) for v in data]
    if not all(math.isfinite(v) for v in out):
        raise ValueError(f"the action is not finite: {out}")
    return out


class NoParameterSearch(NotImplementedError):
    """A harness without :meth:`PolicyHarness.parameter_keys` and
    :meth:`PolicyHarness.variant_near`: its scenarios' feasible sets cannot be searched."""


class PolicyHarness(ABC):
    """A domain's side of policy testing; see the module docstring."""

    #: What the report and terminal call the robot under test ("ego-vehicle", "robot arm").
    robot: ClassVar[str] = "robot"
    #: Built-in policies: name -> one line (``--policy NAME``); a file or module spec also works.
    builtin: ClassVar[Mapping[str, str]] = {}
    #: Default wall time a policy may take per step [s].
    step_timeout: ClassVar[float] = 1.0
    #: Units of the variant parameters that tests.json and the terminal report.
    parameter_units: ClassVar[Mapping[str, str]] = {}

    def robot_name(self, scenario: Scenario) -> str:
        """The entity the policy drives: the scenario's robot (:meth:`Scenario.robot`)."""
        robot = scenario.robot()
        if robot is None:
            raise ValueError(f"scenario {scenario.id} has no robot entity")
        return robot.name

    @abstractmethod
    def load_policy(self, spec: str) -> Policy:
        """A built-in name, ``path/to/file.py[:name]`` or ``module:name``; ConfigError saying
        what to give when it does not load."""

    @abstractmethod
    def action_to_wire(self, action: Any) -> list[float]:
        """A policy's return value as plain numbers; ValueError naming what is wrong. Runs in the
        policy's own process (:mod:`regen.harness.worker`), so converting a strange object is
        the policy's time and the policy's fault."""

    @abstractmethod
    def action_from_wire(self, data: Any) -> Any:
        """The domain's action from what :meth:`action_to_wire` sent (checked again: the policy's
        process may send anything); ValueError or TypeError when it is not an action."""

    @abstractmethod
    def prepare(self, scenario: Scenario) -> Any:
        """What every episode of one scenario shares (compiled programs, loaded scenes)."""

    @abstractmethod
    def run_policy(self, prepared: Any, policy: Policy, *, step_timeout: float) -> Episode:
        """Run one episode with the policy in place of the scripted robot; a policy fault ends
        the episode with ``failure`` set (never raises for it). SimulationError for the
        simulator's own faults."""

    @abstractmethod
    def incidents(self, scenario: Scenario, trace: Trace) -> list[Incident]:
        """Failures of the robot under test besides the FSM, in time order (a collision names
        the robot among its actors)."""

    def excused(self, scenario: Scenario, template_trace: Trace) -> set[str]:
        """Kinds of incident a policy is not failed for because the scripted robot's own run of
        the same variant has them too (default: the kinds of its incidents)."""
        return {i.kind for i in self.incidents(scenario, template_trace)}

    def metrics(self, scenario: Scenario, trace: Trace) -> dict[str, float | None]:
        """Figures each test case records (e.g. ``min_ttc`` [s], ``min_distance`` [m])."""
        return {}

    def oracle_stages(self, scenario: Scenario) -> list[list[StateRef]]:
        """What the policy must bring about, stage by stage and in order: by default the robot's
        own states of each FSM stage (stages without one dropped). A domain whose FSM speaks of
        the world the robot changes (a door open, a pet outside) returns those states instead."""
        robot = self.robot_name(scenario)
        out = []
        for stage in scenario.fsm.stages:
            mine = [c for c in stage.conditions if c.actor == robot]
            if mine:
                out.append(mine)
        return out

    def oracle_state(self, scenario: Scenario, state: AbstractState) -> AbstractState:
        """The robot's FSM state as the oracle checks it: the scripted robot's manner (how hard
        it brakes, say) may be dropped so that only the behavior itself is asked for."""
        return state

    @abstractmethod
    def sample_variants(self, scenario: Scenario, n: int, seed: int, *, extremes: bool = False
                        ) -> list[Scenario]:
        """Up to ``n`` points of the scenario's feasible set, the scenario as grounded first."""

    @abstractmethod
    def check_template(self, scenario: Scenario) -> TemplateRun:
        """The scripted robot simulated and verified in a variant."""

    def parameter_keys(self, scenario: Scenario) -> list[tuple[str, str]]:
        """The (entity, parameter) axes a parameter search may move in the scenario, in a fixed
        order (``regen falsify``'s parameter stage samples one unit-box target per key). By
        default the harness has no parameter search: :class:`NoParameterSearch`."""
        raise NoParameterSearch(f"the {type(self).__name__} has no parameter search")

    def variant_near(self, scenario: Scenario, targets: Mapping[tuple[str, str], float], seed: int
                     ) -> Scenario | None:
        """The point of the scenario's feasible set nearest to ``targets`` (per key of
        :meth:`parameter_keys`, a share in [0, 1] of a span the harness documents: 0 one end,
        1 the other), as a scenario that differs only in its parameters; a key without a target
        stays near its grounded value. None when no feasible point is found. Deterministic for
        ``seed``. By default the harness has no parameter search: :class:`NoParameterSearch`."""
        raise NoParameterSearch(f"the {type(self).__name__} has no parameter search")

    def failure_picture(self, scenario: Scenario, episode: Episode, prepared: Any, case: Any,
                        policy: str, out: Path) -> Path | None:
        """A picture of a failed episode written at ``out`` (a GIF), or None."""
        return None


__all__ = ["Episode", "Incident", "NoParameterSearch", "Policy", "PolicyHarness", "TemplateRun", "wire_numbers"]
