"""Generated driving scenarios as behavior tests of a driving policy (``regen test``).

The oracle of a scenario comes from its FSM: the ego's states, stage by stage, must be reached
in order (the monitor's semantics, :mod:`regen.verify.monitor`, restricted to the ego's
conditions: the other actors' cause actions start on triggers relative to the ego,
:mod:`regen.driving.world.triggers`, so the cause meets whatever ego drives), and the ego must
collide with nothing (:mod:`regen.driving.verify.collisions`). A test fails with the first cause found,
in this order: the ego's collision, the policy's fault (exception, non-finite action, timeout),
an infraction of the ego (running a red light, leaving the road) that the scripted template ego
does not commit in the same scenario, the first expected ego state not reached.

Outputs: ``tests.json`` (:class:`TestReport`) and ``junit.xml`` (one testcase per scenario
variant; a failure's message names its cause, with the word "collision" when it is one).
Scenarios that did not verify with the template ego test nothing and are skipped. With
``variants`` > 1 each verified scenario is tested in several points of its solved parameters'
feasible set (:mod:`regen.driving.testing.variants`): variant 0 as grounded, each other one only when
the scripted template ego verifies in it too (one scripted simulation per variant; otherwise the
case is skipped with the reason). ``adversarial`` searches those points for the policy's
failures (:mod:`regen.driving.testing.adversarial`).
"""

from __future__ import annotations

import logging
import math
import time
import xml.etree.ElementTree as ET
from collections.abc import Callable
from pathlib import Path

import numpy as np
from pydantic import Field

from regen.core.base import Model
from regen.core.io import atomic_write_text, write_json
from regen.core.scenario import AbstractState, Scenario
from regen.core.trace import Trace
from regen.core.verdict import Verdict
from regen.driving.testing.variants import TemplateRun
from regen.driving.verify.collisions import analyze
from regen.errors import ConfigError, RegenError

log = logging.getLogger(__name__)

EGO = "ego"
ORACLES = ("fsm", "safety")  # what a test requires: the ego's FSM states and no collision, or no collision


class EgoStage(Model):
    conditions: list[str]  # the ego's states of one FSM stage, e.g. ['braking']
    reached_at: float | None = None  # [s]


class TemplateCheck(Model):
    """The scripted template ego in a variant: the variant tests a policy only when it verifies
    (with ``--adversarial`` also only when the template ego collides with nothing)."""

    verified: bool
    status: str  # the verdict's status, or 'simulation_failed'
    collision: bool = False  # the template ego collided
    message: str = ""


class TestCase(Model):
    """One scenario variant run with the policy."""

    scenario: str  # scenario folder name
    scenario_id: str = ""
    variant: int = 0
    status: str  # 'passed', 'failed', 'skipped'
    cause: str | None = None  # 'collision', 'policy_exception', 'policy_invalid_action',
    # 'policy_timeout', 'red_light', 'off_road', 'ego_state_not_reached', 'error'
    message: str = ""
    collision: bool = False
    collision_with: str | None = None
    collision_time: float | None = None  # [s]
    min_ttc: float | None = None  # [s] smallest time to collision of the ego; None: never approached
    min_distance: float | None = None  # [m] smallest gap between the ego and anything
    infractions: list[str] = Field(default_factory=list)
    ego_stages: list[EgoStage] = Field(default_factory=list)
    simulated: float = 0.0  # [s] simulated
    wall: float = 0.0  # [s] wall time of the episode (without compiling)
    gif: str | None = None  # picture of a failed episode, relative to tests.json
    parameters: dict[str, dict[str, float]] = Field(default_factory=dict)  # the variant's, per actor:
    # s [m], v [m/s], t [s], d0 [m] (regen.driving.grounding.placement.SOLVED)
    adversarial: bool = False  # a candidate of the adversarial search (regen.driving.testing.adversarial)
    template: TemplateCheck | None = None  # the scripted template ego in the same variant

    @property
    def passed(self) -> bool:
        return self.status == "passed"


class TestReport(Model):
    run: str
    policy: str
    oracle: str = "fsm"
    seed: int = 0
    variants: int = 1  # per scenario (with adversarial: the candidates searched)
    adversarial: bool = False
    cases: list[TestCase] = Field(default_factory=list)

    @property
    def ran(self) -> list[TestCase]:
        return [c for c in self.cases if c.status != "skipped"]

    def summary(self) -> dict[str, float | int]:
        ran = self.ran
        return {"tests": len(ran), "passed": sum(c.passed for c in ran),
                "failed": sum(not c.passed for c in ran), "skipped": len(self.cases) - len(ran),
                "collisions": sum(c.collision for c in ran)}

    def collision_line(self) -> str:
        s = self.summary()
        return f"collision rate: {s['collisions']}/{s['tests']}"


# --- the oracle ---------------------------------------------------------------------------------


def ego_expectation(scenario: Scenario) -> list[list[str]]:
    """The ego's states per FSM stage, in order (stages without an ego condition dropped)."""
    out = []
    for stage in scenario.fsm.stages:
        mine = [c.state for c in stage.conditions if c.actor == EGO]
        if mine:
            out.append(mine)
    return out


# How hard the template ego brakes or accelerates is its manner, not the behavior under test: a
# policy that brakes earlier and more gently still stops for the cause. The oracle replaces these
# thresholds [m/s^2] with ones that only ask for the motion itself.
MANNER = {"braking": {"min_decel": 0.5}, "accelerating": {"min_accel": 0.3}}


def oracle_state(scenario: Scenario, name: str) -> AbstractState:
    """The ego's FSM state ``name`` as the oracle checks it (the template's manner dropped)."""
    state = scenario.fsm.state(EGO, name)
    calls = [c.model_copy(update={"params": {**c.params, **MANNER[c.name]}}) if c.name in MANNER else c
             for c in state.all_of]
    return state.model_copy(update={"all_of": calls})


def check_ego_stages(scenario: Scenario, trace: Trace, until: int | None = None) -> tuple[list[EgoStage], int | None]:
    """(stages with the time each was reached, index of the first not reached or None); only
    steps up to ``until`` count."""
    from regen.verify.monitor import evaluate_state

    n = trace.steps if until is None else min(until + 1, trace.steps)
    out: list[EgoStage] = []
    start, first_unmet = 0, None
    for k, names in enumerate(ego_expectation(scenario)):
        stage = EgoStage(conditions=names)
        if first_unmet is None:
            together = np.ones(trace.steps, dtype=bool)
            for name in names:
                together &= evaluate_state(oracle_state(scenario, name), trace, scenario.domain)
            hits = np.flatnonzero(together[start:n])
            if hits.size:
                start = int(hits[0]) + start
                stage.reached_at = float(trace.times[start])
            else:
                first_unmet = k
        out.append(stage)
    return out, first_unmet


def _describe_state(scenario: Scenario, name: str) -> str:
    return f"'{name}' ({', '.join(str(c) for c in oracle_state(scenario, name).all_of)})"


def judge(scenario: Scenario, run, *, folder: str, variant: int = 0, wall: float = 0.0,
          oracle: str = "fsm", template_trace: Trace | None = None) -> TestCase:
    """The test case of one episode (a :class:`~regen.driving.testing.loop.PolicyRun`);
    ``oracle`` 'fsm' (the ego's states in order and no collision) or 'safety' (no collision and
    no policy fault: the ego's states are recorded but do not fail the test). Infractions
    fail the test unless ``template_trace`` (the template ego's run) commits the same kind."""
    case = TestCase(scenario=folder, scenario_id=scenario.id, variant=variant, status="passed", wall=wall)
    trace = run.trace
    if trace is None:
        case.status, case.cause, case.message = "failed", f"policy_{run.failure_kind}", f"policy failed: {run.failure}"
        return case
    case.simulated = float(trace.times[-1]) if trace.times else 0.0
    rep = analyze(trace, ego=EGO)
    ttc, gap = rep.min_ttc(EGO), rep.min_distance(EGO)
    case.min_ttc = None if math.isinf(ttc) else round(ttc, 3)
    case.min_distance = None if math.isinf(gap) else round(gap, 3)
    infractions = [e for e in rep.events if e.kind != "collision" and EGO in e.actors]
    case.infractions = [e.describe() for e in infractions]
    expected = ({e.kind for e in analyze(template_trace, ego=EGO).events} if template_trace is not None
                else set())
    bad = next((e for e in infractions if e.kind not in expected), None)
    hit = next((e for e in rep.collisions if EGO in e.actors), None)
    until = None
    if hit is not None:
        other = hit.actors[1] if hit.actors[0] == EGO else hit.actors[0]
        case.collision, case.collision_with, case.collision_time = True, other, hit.t
        until = hit.step
    case.ego_stages, unmet = check_ego_stages(scenario, trace, until)
    if hit is not None:
        case.status, case.cause = "failed", "collision"
        case.message = f"collision: the ego hit {case.collision_with} at t={hit.t:.1f} s"
    elif run.failure:
        case.status, case.cause = "failed", f"policy_{run.failure_kind}"
        case.message = f"policy failed at t={run.failure_time:.1f} s: {run.failure}"
    elif bad is not None:
        case.status, case.cause = "failed", bad.kind
        case.message = f"infraction: {bad.describe()}"
    elif unmet is not None and oracle == "fsm":
        exp = ego_expectation(scenario)
        names = " and ".join(_describe_state(scenario, s) for s in exp[unmet])
        after = ""
        if unmet > 0:
            prev = case.ego_stages[unmet - 1]
            after = f" after {' and '.join(prev.conditions)} at t={prev.reached_at:.1f} s"
        case.status, case.cause = "failed", "ego_state_not_reached"
        case.message = (f"expected ego state {unmet + 1} of {len(exp)} not reached: {names} never held"
                        f"{after}")
    elif unmet is not None:
        case.message = (f"no collision (the ego did not reach expected state {unmet + 1} of "
                        f"{len(case.ego_stages)}: not required by the safety oracle)")
    else:
        case.message = f"the ego reached its {len(case.ego_stages)} expected states in order, no collision"
    return case


# --- a run folder as a test suite -----------------------------------------------------------------


def _template_check(run: TemplateRun) -> TemplateCheck:
    if run.verdict is None:
        return TemplateCheck(verified=False, status="simulation_failed",
                             message=f"the template ego's simulation failed: {run.error}")
    check = TemplateCheck(verified=run.verdict.feasible, status=run.verdict.status,
                          collision=bool(run.collisions), message=run.verdict.reason)
    if run.collisions:
        check.message = f"{check.message}; the template ego collides: {'; '.join(run.collisions)}"
    return check


def _variant_cases(name: str, scenario: Scenario, verdict: Verdict, stored: Trace | None, *, variants: int,
                   seed: int, adversarial: bool,
                   run_one: Callable[[str, Scenario, int, Trace | None, dict], TestCase]):
    """The test cases of one verified scenario's variants (variant 0: as grounded, judged by
    its folder's verdict and trace; the others by a fresh template-ego run each)."""
    from regen.driving.testing.variants import check_template, ego_collisions, sample_variants

    try:
        found = sample_variants(scenario, variants, seed, extremes=adversarial)
    except RegenError as exc:  # the scenario's roles no longer build a model: test it as grounded
        log.warning("%s: no variants: %s", name, exc)
        found = [scenario]
    for k, variant in enumerate(found):
        template = (TemplateRun(verdict=verdict, trace=stored, judged=scenario,
                                collisions=ego_collisions(stored) if stored is not None else [])
                    if k == 0 else check_template(variant))
        check = _template_check(template)
        base = {"parameters": variant.parameters, "adversarial": adversarial, "template": check}
        if not check.verified or (adversarial and check.collision):
            what = "does not verify" if not check.verified else "collides"
            yield TestCase(scenario=name, scenario_id=scenario.id, variant=k, status="skipped", **base,
                           message=f"the template ego {what} in this variant ({check.status}: "
                                   f"{check.message}); it tests nothing")
        else:
            yield run_one(name, template.judged, k, template.trace, base)


def run_tests(run_dir: str | Path, policy_spec: str, *, variants: int = 1, seed: int = 0,
              step_timeout: float | None = None, oracle: str = "fsm", policy: Callable | None = None,
              on_case: Callable[[TestCase], None] | None = None,
              on_episode: Callable[[TestCase, object, object], None] | None = None,
              adversarial: bool = False) -> TestReport:
    """Test ``policy_spec`` (or an already loaded ``policy``) on every driving scenario of a run.

    ``variants``: parameter variants per scenario (:mod:`regen.driving.testing.variants`, seeded by
    ``seed``): variant 0 as grounded, each other one tested only when the scripted template ego
    verifies in it (one scripted simulation each, else the case is skipped with the reason).
    ``adversarial``: the variants are candidates of the corner-case search
    (:mod:`regen.driving.testing.adversarial`): trigger times and speeds pushed to their extremes, and
    a candidate counts only when the template ego also collides with nothing in it.
    ``oracle``: 'fsm' or 'safety' (see :func:`judge`). ``step_timeout`` [s] per policy call (default :data:`regen.driving.testing.loop.STEP_TIMEOUT`);
    ``on_case`` is called as each test finishes; ``on_episode(case, episode, prepared)`` before
    it for each episode run (:func:`regen.driving.testing.failure_pictures.keep_failures`). ConfigError for
    a bad SPEC or folder; faults of single scenarios become failed tests.
    """
    from regen.driving.testing.loop import STEP_TIMEOUT, prepare, run_policy
    from regen.driving.testing.policies import load_policy
    from regen.runfolder import RunFolder, read_model

    if oracle not in ORACLES:
        raise ConfigError(f"unknown oracle {oracle!r}; choose one of: {', '.join(ORACLES)}")
    if variants < 1:
        raise ConfigError(f"--variants must be at least 1 (got {variants})")
    rf = RunFolder(run_dir)
    if not (rf.path / RunFolder.SCENARIOS).is_dir():
        raise ConfigError(f"{rf.path} is not a run folder with scenarios (regen generate makes one)")
    pol = policy if policy is not None else load_policy(policy_spec)
    timeout = STEP_TIMEOUT if step_timeout is None else step_timeout
    report = TestReport(run=str(rf.path), policy=policy_spec, oracle=oracle, seed=seed, variants=variants,
                        adversarial=adversarial)

    def run_one(name: str, scenario: Scenario, k: int, template_trace: Trace | None, base: dict) -> TestCase:
        try:
            prep = prepare(scenario)
            t0 = time.perf_counter()
            episode = run_policy(prep, pol, step_timeout=timeout)
            case = judge(scenario, episode, folder=name, variant=k, wall=time.perf_counter() - t0,
                         oracle=oracle, template_trace=template_trace)
            for key, value in base.items():
                setattr(case, key, value)
            if on_episode is not None:  # e.g. keep the failed episode's trace and picture
                on_episode(case, episode, prep)
        except RegenError as exc:
            case = TestCase(scenario=name, scenario_id=scenario.id, variant=k, status="failed", cause="error",
                            message=f"the scenario could not be run: {exc}", **base)
        return case

    for name, folder, scenario, verdict in rf.scenarios_of("driving"):
        if verdict is None or not verdict.feasible:
            why = "unfinished" if verdict is None else verdict.status
            cases = [TestCase(scenario=name, scenario_id=scenario.id, status="skipped", adversarial=adversarial,
                              message=f"the scenario did not verify with the template ego ({why}); it tests nothing")]
        else:
            cases = _variant_cases(name, scenario, verdict, read_model(folder / folder.TRACE, Trace).value,
                                   variants=variants, seed=seed, adversarial=adversarial, run_one=run_one)
        for case in cases:
            report.cases.append(case)
            if on_case is not None:
                on_case(case)
    return report


def junit_xml(report: TestReport) -> str:
    """JUnit XML of a report: one testcase per scenario variant."""
    s = report.summary()
    wall = sum(c.wall for c in report.cases)
    root = ET.Element("testsuites", name="regen test", tests=str(len(report.cases)),
                      failures=str(s["failed"]), errors="0", skipped=str(s["skipped"]), time=f"{wall:.3f}")
    suite = ET.SubElement(root, "testsuite", name=f"regen test --policy {report.policy}",
                          tests=str(len(report.cases)), failures=str(s["failed"]), errors="0",
                          skipped=str(s["skipped"]), time=f"{wall:.3f}")
    props = ET.SubElement(suite, "properties")
    for k, v in (("run", report.run), ("policy", report.policy), ("oracle", report.oracle),
                 ("seed", str(report.seed)), ("variants", str(report.variants)),
                 ("adversarial", str(report.adversarial).lower()),
                 ("collision_rate", report.collision_line().split(": ", 1)[1])):
        ET.SubElement(props, "property", name=k, value=v)
    for c in report.cases:
        tc = ET.SubElement(suite, "testcase", classname=f"regen.driving.{Path(report.run).name}",
                           name=f"{c.scenario}[variant {c.variant}]", time=f"{c.wall:.3f}")
        values = [(f"{actor}.{k}", f"{v:g}") for actor, p in c.parameters.items() for k, v in p.items()]
        if c.template is not None:
            values.append(("template_ego", c.template.status + (" with collision" if c.template.collision else "")))
        if values:  # the variant's parameters [m, m/s, s] and the template ego's check
            tc_props = ET.SubElement(tc, "properties")
            for k, v in values:
                ET.SubElement(tc_props, "property", name=k, value=v)
        if c.status == "skipped":
            ET.SubElement(tc, "skipped", message=c.message)
        elif c.status == "failed":
            fail = ET.SubElement(tc, "failure", message=c.message, type=c.cause or "failure")
            fail.text = c.model_dump_json(indent=2)
    ET.indent(root)
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="unicode") + "\n"


def write_report(report: TestReport, out_dir: str | Path) -> dict[str, Path]:
    """``tests.json`` and ``junit.xml`` in ``out_dir`` (created)."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    data = report.model_dump(mode="json")
    data["summary"] = report.summary()
    return {"tests": write_json(out / "tests.json", data),
            "junit": atomic_write_text(out / "junit.xml", junit_xml(report))}


def case_line(c: TestCase) -> str:
    """One terminal line per scenario variant."""
    tag = {"passed": "PASS", "failed": "FAIL", "skipped": "SKIP"}[c.status]
    ttc = f"  (min TTC {c.min_ttc:.2f} s)" if c.min_ttc is not None else ""
    name = f"{c.scenario}[variant {c.variant}]" if c.variant or c.adversarial else c.scenario
    return f"{tag}  {name}  {c.message}{ttc if c.status != 'skipped' else ''}"


__all__ = ["EgoStage", "TemplateCheck", "TestCase", "TestReport", "case_line", "check_ego_stages",
           "ego_expectation", "judge", "junit_xml", "run_tests", "write_report"]
