"""A run folder as a test suite: every verified scenario of the run (and its variants) run with
the user's policy in place of the scripted robot, through the domain's policy harness.

Scenarios that did not verify with the scripted robot test nothing and are skipped. With
``variants`` > 1 each verified scenario is tested in several points of its solved parameters'
feasible set: variant 0 as grounded, each other one only when the scripted robot verifies in it
too (one scripted simulation per variant; otherwise the case is skipped with the reason).
``adversarial`` searches those points for the policy's failures (:mod:`regen.harness.adversarial`).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from regen.core.scenario import Scenario
from regen.core.trace import Trace
from regen.core.verdict import Verdict
from regen.errors import ConfigError, RegenError
from regen.harness.cases import CaseResult, SuiteReport, TemplateCheck
from regen.harness.contract import PolicyHarness, TemplateRun
from regen.harness.oracle import ORACLES, judge

log = logging.getLogger(__name__)


def harness_for(domain: str) -> PolicyHarness:
    """The policy harness of a registered domain; ConfigError when the domain has none."""
    from regen import domains

    harness = domains.make(domain).policy_harness()
    if harness is None:
        raise ConfigError(f"the {domain} domain has no policy harness: regen test cannot run a policy "
                          "in its scenarios")
    return harness


def run_domain(rf: Any) -> str:
    """The domain of a run folder: its manifest's behavior, else its first readable scenario's."""
    raw = rf.read_manifest_raw()
    domain = raw.value.get("behavior", {}).get("domain") if raw.ok else None
    if isinstance(domain, str) and domain:
        return domain
    for name in rf.scenario_names():
        scenario = rf.scenario(name).scenario()
        if scenario is not None:
            return scenario.domain
    raise ConfigError(f"{rf.path} holds no readable scenario: run regen generate first")


def open_suite(run_dir: str | Path) -> tuple[Any, str, PolicyHarness]:
    """(run folder, its domain, the domain's policy harness); ConfigError saying what to do when
    the folder holds no scenarios or the domain tests no policies."""
    from regen.runfolder import RunFolder

    rf = RunFolder(run_dir)
    if not (rf.path / RunFolder.SCENARIOS).is_dir():
        raise ConfigError(f"{rf.path} is not a run folder with scenarios (regen generate makes one)")
    domain = run_domain(rf)
    return rf, domain, harness_for(domain)


def template_check(run: TemplateRun) -> TemplateCheck:
    """The scripted robot's run in a variant, as a case records it (verified, collided, why)."""
    if run.verdict is None:
        return TemplateCheck(verified=False, status="simulation_failed",
                             message=f"the scripted robot's simulation failed: {run.error}")
    check = TemplateCheck(verified=run.verdict.feasible, status=run.verdict.status,
                          collision=bool(run.collisions), message=run.verdict.reason)
    if run.collisions:
        check.message = f"{check.message}; the scripted robot collides: {'; '.join(run.collisions)}"
    return check


def _variant_cases(harness: PolicyHarness, name: str, scenario: Scenario, verdict: Verdict,
                   stored: Trace | None, *, variants: int, seed: int, adversarial: bool,
                   run_one: Callable[[str, Scenario, int, Trace | None, dict], CaseResult],
                   reuse: Callable[[int], CaseResult | None]):
    """The cases of one verified scenario's variants (variant 0: as grounded, judged by its
    folder's verdict and trace; the others by a fresh scripted run each). ``reuse(k)``: the
    finished case of an earlier run, which is kept without running anything."""
    try:
        found = harness.sample_variants(scenario, variants, seed, extremes=adversarial)
    except RegenError as exc:  # the scenario no longer builds a placement model: test it as grounded
        log.warning("%s: no variants: %s", name, exc)
        found = [scenario]
    for k, variant in enumerate(found):
        kept = reuse(k)
        if kept is not None:
            yield kept
            continue
        try:
            if k == 0:
                hits = ([i.message for i in harness.incidents(scenario, stored) if i.collision]
                        if stored is not None else [])
                template = TemplateRun(verdict=verdict, trace=stored, judged=scenario, collisions=hits)
            else:
                template = harness.check_template(variant)
        except Exception as exc:  # noqa: BLE001 - one broken scenario is one error case
            yield _error_case(name, scenario.id, k, adversarial, exc)
            continue
        check = template_check(template)
        base = {"parameters": _numeric(variant.parameters), "adversarial": adversarial, "template": check}
        if not check.verified or (adversarial and check.collision):
            what = "does not verify" if not check.verified else "collides"
            yield CaseResult(scenario=name, scenario_id=scenario.id, variant=k, status="skipped", **base,
                             message=f"the scripted {harness.robot} {what} in this variant ({check.status}: "
                                     f"{check.message}); it tests nothing")
        else:
            yield run_one(name, template.judged or variant, k, template.trace, base)


def _error_case(name: str, scenario_id: str, k: int, adversarial: bool, exc: BaseException | str,
                base: dict | None = None) -> CaseResult:
    """A case that could not be run: a failure of the suite, JUnit ``error``, never dropped."""
    why = exc if isinstance(exc, str) else (str(exc) if isinstance(exc, RegenError)
                                            else f"{type(exc).__name__}: {exc}")
    fields = {**(base or {}), "adversarial": adversarial}
    return CaseResult(scenario=name, scenario_id=scenario_id, variant=k, status="failed", cause="error",
                      message=f"the scenario could not be run: {why}", **fields)


def _numeric(parameters: dict) -> dict[str, dict[str, float]]:
    """The variant's numeric parameters per actor (what tests.json records)."""
    return {actor: {k: float(v) for k, v in p.items() if isinstance(v, (int, float)) and not isinstance(v, bool)}
            for actor, p in parameters.items()}


def _suite_entries(rf: Any, domain: str) -> Iterator[tuple[str, Any, Scenario | None, Verdict | None, str]]:
    """(name, folder, scenario, verdict, problem) of every scenario folder of the run in run
    order: a scenario of another domain is left out; one whose files cannot be read comes with
    the problem (a verified scenario must never vanish from the results)."""
    from regen.runfolder import read_model

    for name in rf.scenario_names():
        folder = rf.scenario(name)
        loaded = read_model(folder / folder.SCENARIO, Scenario, key="scenario")
        verdict = read_model(folder / folder.VERDICT, Verdict)
        if loaded.ok:
            if loaded.value.domain != domain:
                continue
            problem = "" if verdict.ok or not (folder / folder.VERDICT).exists() else \
                f"{folder.VERDICT} {verdict.problem}"
            yield name, folder, loaded.value, verdict.value, problem
        elif (folder / folder.SCENARIO).exists() or verdict.ok:
            yield name, folder, None, verdict.value, f"{folder.SCENARIO} {loaded.problem}"


def run_tests(run_dir: str | Path, policy_spec: str, *, variants: int = 1, seed: int = 0,
              step_timeout: float | None = None, oracle: str = "fsm", policy: Callable | None = None,
              on_case: Callable[[CaseResult], None] | None = None,
              on_episode: Callable[[CaseResult, object, object], None] | None = None,
              adversarial: bool = False, harness: PolicyHarness | None = None,
              out: str | Path | None = None, on_note: Callable[[str], None] | None = None) -> SuiteReport:
    """Test ``policy_spec`` on every scenario of a run, the policy in its own process.

    ``variants``: parameter variants per scenario, seeded by ``seed``. ``adversarial``: the
    variants are candidates of the corner-case search (their parameters pushed to the ends of
    their feasible ranges), and a candidate counts only when the scripted robot also collides
    with nothing in it. ``oracle``: 'fsm' or 'safety' (see :func:`regen.harness.oracle.judge`).
    ``step_timeout`` [s] per policy call (default: the harness's); ``on_case`` is called as each
    test finishes; ``on_episode(case, episode, prepared)`` before it for each episode run
    (:func:`regen.harness.pictures.keep_failures`).

    ``out``: the results folder (:mod:`regen.harness.results`): locked, each case written the
    moment it finishes, ``tests.json`` and ``junit.xml`` rebuilt after each, and a rerun of the
    same call resumes (``on_note`` hears when it starts over). Ctrl-C lets the current case
    finish and raises KeyboardInterrupt with every finished case written.

    ``policy``: an already loaded callable run in this process instead (a library user's own
    trusted object: it is not isolated). ConfigError for a bad SPEC or folder, or a domain
    without a policy harness; faults of single scenarios become failed (error) tests.
    """
    from regen.harness.process import PolicyProcess
    from regen.harness.results import POLICY_LOG, ResultsFolder, policy_digest

    if oracle not in ORACLES:
        raise ConfigError(f"unknown oracle {oracle!r}; choose one of: {', '.join(ORACLES)}")
    if variants < 1:
        raise ConfigError(f"--variants must be at least 1 (got {variants})")
    results = ResultsFolder(out) if out is not None else None
    if results is not None:
        results.check()
    rf, domain, found = open_suite(Path(run_dir).absolute())
    harness = harness or found
    timeout = harness.step_timeout if step_timeout is None else step_timeout
    report = SuiteReport(run=str(rf.path), policy=policy_spec, domain=domain, robot=harness.robot,
                         oracle=oracle, seed=seed, variants=variants, adversarial=adversarial)
    suite = _Suite(harness=harness, report=report, oracle=oracle, variants=variants, seed=seed,
                   adversarial=adversarial, timeout=timeout, results=results, policy=policy,
                   on_case=on_case, on_episode=on_episode, on_note=on_note)
    try:
        if results is not None:
            results.lock()
        if policy is None:
            suite.remote = PolicyProcess(harness, policy_spec,
                                         log_path=results.path / POLICY_LOG if results is not None else None)
            try:
                suite.remote.start()
            except RegenError as exc:  # a refused policy leaves nothing behind, nor changes earlier results
                raise (exc if results is None else results.refused(exc)) from None
        if results is not None:  # after the policy loaded: a refused policy leaves nothing in the run
            settings = {"policy": policy_spec, "policy_digest": policy_digest(policy_spec),
                        "variants": variants, "seed": seed, "oracle": oracle, "step_timeout": timeout,
                        "adversarial": adversarial, "in_process": policy is not None}
            note = results.open(settings)
            if note and on_note is not None:
                on_note(note)
            results.hold_run(rf.path)
        suite.run(rf, domain)
        if results is not None:
            results.write(report)
    finally:
        if suite.remote is not None:
            suite.remote.close()
        if results is not None:
            results.close()
    return report


def run_case(harness: PolicyHarness, policy: Any, scenario: Scenario, *, name: str, variant: int, timeout: float,
             oracle: str, template_trace: Trace | None) -> tuple[CaseResult, Any, Any]:
    """One episode of ``policy`` (a callable, or the PolicyProcess running it) in ``scenario``,
    judged by the oracle: (the case, the episode, what the harness prepared). Exceptions of the
    harness propagate (the caller makes them an error case)."""
    prepared = harness.prepare(scenario)
    t0 = time.perf_counter()
    episode = harness.run_policy(prepared, policy, step_timeout=timeout)
    case = judge(harness, scenario, episode, folder=name, variant=variant, wall=time.perf_counter() - t0,
                 oracle=oracle, template_trace=template_trace)
    return case, episode, prepared


@dataclass
class _Suite:
    """One call of :func:`run_tests` once its policy runs: the cases of each scenario folder,
    each judged and recorded (in ``report``, and in ``results`` when given) as it finishes."""

    harness: PolicyHarness
    report: SuiteReport
    oracle: str
    variants: int
    seed: int
    adversarial: bool
    timeout: float  # [s] per policy call
    results: Any  # the ResultsFolder, or None
    policy: Callable | None  # the in-process policy, or None: ``remote`` runs it
    on_case: Callable[[CaseResult], None] | None
    on_episode: Callable[[CaseResult, object, object], None] | None
    on_note: Callable[[str], None] | None
    remote: Any = None  # the PolicyProcess
    reused: list[CaseResult] = field(default_factory=list)  # cases kept from an earlier run

    def run(self, rf: Any, domain: str) -> None:
        """Every case of every scenario folder of the run, in run order; a first Ctrl-C lets the
        current case finish and keeps it, then raises KeyboardInterrupt."""
        from regen.harness.results import scenario_digest
        from regen.interrupts import Interrupts
        from regen.report.load import causal_text

        with Interrupts() as interrupts:
            for name, folder, scenario, verdict, problem in _suite_entries(rf, domain):
                digest = scenario_digest(folder.path) if self.results is not None else ""
                cases = self.cases(name, folder, scenario, verdict, problem, digest)
                if cases is None:
                    continue
                pending = iter(cases)
                causal = causal_text(verdict.causal) if verdict is not None else None
                while True:
                    with interrupts.deferred():  # a first Ctrl-C lets this case finish and keeps it
                        case = next(pending, None)
                    if case is None:
                        break
                    case.causal = causal  # the scenario's causal check, beside the test's result
                    self.record(case, digest)
                    interrupts.check()

    def cases(self, name: str, folder: Any, scenario: Scenario | None, verdict: Verdict | None, problem: str,
              digest: str) -> Iterable[CaseResult] | None:
        """The cases of one scenario folder: an error case for one that cannot be read, a skipped
        case for one that did not verify, else its variants' (None: it tests nothing, left out)."""
        from regen.runfolder import read_model

        adversarial = self.adversarial
        if scenario is None or problem:
            if verdict is not None and not verdict.feasible:
                return None  # an unreadable scenario that did not verify tests nothing anyway
            return [_error_case(name, scenario.id if scenario else "", 0, adversarial, f"its {problem}")]
        if verdict is None or not verdict.feasible:
            why = "unfinished" if verdict is None else verdict.status
            return [CaseResult(scenario=name, scenario_id=scenario.id, status="skipped", adversarial=adversarial,
                               message=f"the scenario did not verify with the scripted {self.harness.robot} "
                                       f"({why}); it tests nothing")]
        return _variant_cases(self.harness, name, scenario, verdict,
                              read_model(folder / folder.TRACE, Trace).value, variants=self.variants,
                              seed=self.seed, adversarial=adversarial, run_one=self.run_one,
                              reuse=lambda k: self.reuse(name, digest, k))

    def reuse(self, name: str, digest: str, k: int) -> CaseResult | None:
        """The finished case of variant ``k`` from an earlier run of the same call, if any."""
        kept = self.results.reuse(f"{name}-v{k}", digest) if self.results is not None else None
        if kept is not None and not self.reused and self.on_note is not None:
            self.on_note("resuming: the cases this command finished before are kept, not run again")
        if kept is not None:
            self.reused.append(kept)
        return kept

    def run_one(self, name: str, scenario: Scenario, k: int, template_trace: Trace | None,
                base: dict) -> CaseResult:
        """The policy in one variant of a scenario, judged by the oracle (an error case if it breaks)."""
        if self.remote is not None:
            self.remote.ensure_fresh()  # a policy that faulted in the last case starts afresh
        pol = self.policy if self.policy is not None else self.remote
        try:
            case, episode, prep = run_case(self.harness, pol, scenario, name=name, variant=k, timeout=self.timeout,
                                           oracle=self.oracle, template_trace=template_trace)
            for key, value in base.items():
                setattr(case, key, value)
            if self.on_episode is not None:  # e.g. keep the failed episode's trace and picture
                self.on_episode(case, episode, prep)
        except Exception as exc:  # noqa: BLE001 - one broken scenario is one error case
            case = _error_case(name, scenario.id, k, self.adversarial, exc, base)
        return case

    def record(self, case: CaseResult, digest: str) -> None:
        """A finished case: in the report, written to the results folder, told to ``on_case``."""
        self.report.cases.append(case)
        if self.results is not None:
            self.results.keep(case, digest)
            self.results.write(self.report)
        if self.on_case is not None:
            self.on_case(case)


__all__ = ["harness_for", "open_suite", "run_case", "run_domain", "run_tests", "template_check"]
