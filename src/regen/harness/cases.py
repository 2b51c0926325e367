"""The results of policy tests: one :class:`CaseResult` per scenario variant, one
:class:`SuiteReport` per ``regen test`` (written as ``tests.json``)."""

from __future__ import annotations

from pydantic import AliasChoices, Field

from regen.core.base import Model


class RobotStage(Model):
    """One stage of the oracle: states that must hold together, and when they first did."""

    conditions: list[str]  # e.g. ['braking'] or ['door1: open']
    reached_at: float | None = None  # [s]


class TemplateCheck(Model):
    """The scripted robot in a variant: the variant tests a policy only when it verifies (with
    ``--adversarial`` also only when the scripted robot collides with nothing)."""

    verified: bool
    status: str  # the verdict's status, or 'simulation_failed'
    collision: bool = False  # the scripted robot collided
    message: str = ""


class CaseResult(Model):
    """One scenario variant run with the policy."""

    scenario: str  # scenario folder name
    scenario_id: str = ""
    variant: int = 0
    status: str  # 'passed', 'failed', 'skipped'
    # 'collision', 'policy_exception', 'policy_invalid_action', 'policy_timeout', 'policy_crash'
    # (its process ended), an incident's kind (e.g. 'red_light', 'displaced'),
    # 'state_not_reached', 'error' (the scenario could not be run: JUnit error)
    cause: str | None = None
    message: str = ""
    collision: bool = False
    collision_with: str | None = None
    collision_time: float | None = None  # [s]
    min_ttc: float | None = None  # [s] smallest time to collision of the robot; None: never approached
    min_distance: float | None = None  # [m] smallest gap between the robot and anything
    metrics: dict[str, float | None] = Field(default_factory=dict)  # the domain's other figures
    infractions: list[str] = Field(default_factory=list)  # incidents other than collisions, in words
    # tests.json files written before the harness was shared call these ego_stages
    robot_stages: list[RobotStage] = Field(default_factory=list,
                                           validation_alias=AliasChoices("robot_stages", "ego_stages"))
    simulated: float = 0.0  # [s] simulated
    wall: float = 0.0  # [s] wall time of the episode (without compiling)
    gif: str | None = None  # picture of a failed episode, relative to tests.json
    parameters: dict[str, dict[str, float]] = Field(default_factory=dict)  # the variant's, per actor
    adversarial: bool = False  # a candidate of the adversarial search (regen.harness.adversarial)
    template: TemplateCheck | None = None  # the scripted robot in the same variant
    #: whether the scenario's cause causes the behavior, from its folder's verdict.json when the
    #: test ran: 'caused', 'not_sufficient', 'confounded: traffic_light1' (confounders appended);
    #: None: that verdict has no causal part. A failure on a confounded scenario is explained by it.
    causal: str | None = None

    @property
    def passed(self) -> bool:
        return self.status == "passed"


class SuiteReport(Model):
    """Every case of one ``regen test`` run (``tests.json``)."""

    run: str
    policy: str
    domain: str = ""
    robot: str = "robot"  # what the domain calls the robot under test
    oracle: str = "fsm"
    seed: int = 0
    variants: int = 1  # per scenario (with adversarial: the candidates searched)
    adversarial: bool = False
    cases: list[CaseResult] = Field(default_factory=list)

    @property
    def ran(self) -> list[CaseResult]:
        return [c for c in self.cases if c.status != "skipped"]

    def summary(self) -> dict[str, float | int]:
        ran = self.ran
        return {"tests": len(ran), "passed": sum(c.passed for c in ran),
                "failed": sum(not c.passed for c in ran), "skipped": len(self.cases) - len(ran),
                "errors": sum(c.cause == "error" for c in ran),
                "collisions": sum(c.collision for c in ran)}

    def collision_line(self) -> str:
        s = self.summary()
        return f"collision rate: {s['collisions']}/{s['tests']}"


def case_line(c: CaseResult) -> str:
    """One terminal line per scenario variant."""
    tag = "ERROR" if c.cause == "error" else {"passed": "PASS", "failed": "FAIL", "skipped": "SKIP"}[c.status]
    ttc = f"  (min TTC {c.min_ttc:.2f} s)" if c.min_ttc is not None else ""
    name = f"{c.scenario}[variant {c.variant}]" if c.variant or c.adversarial else c.scenario
    causal = f"  [causal: {c.causal}]" if c.causal else ""
    return f"{tag}  {name}  {c.message}{ttc if c.status != 'skipped' else ''}{causal}"


__all__ = ["CaseResult", "RobotStage", "SuiteReport", "TemplateCheck", "case_line"]
