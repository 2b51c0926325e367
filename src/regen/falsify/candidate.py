"""One candidate of ``regen falsify``: a verified scenario's cause path with a set of edits
applied (:func:`regen.whatif.apply_edits`), grounded by the rules, simulated and verified with
the scripted robot by the main job's stage function (:func:`regen.pipeline.stages.run_path`),
then the policy run in it by ``regen test``'s own suite (:func:`regen.harness.suite.run_tests`).

Every candidate is a tiny run folder of its own, ``OUT/candidates/<cid>/``: a ``run.json``, its
one scenario in ``scenarios/<cid>/``, the policy's results in ``tests/<policy>/`` (``tests.json``,
``junit.xml``, the failure's GIF, exactly as ``regen test`` writes them) and ``candidate.json``
(:class:`~regen.falsify.record.CandidateRecord`). So ``regen test OUT/candidates/<cid> --policy
SPEC`` replays it.

A candidate is the policy's failure only when the scripted robot verified in it and collided
with nothing (:func:`regen.harness.adversarial.failing`); otherwise it is ``invalid`` with the
reason, never a finding.
"""

from __future__ import annotations

import shlex
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from regen.core.io import write_json
from regen.errors import ConfigError
from regen.falsify.record import (
    CANDIDATE_JSON,
    CANDIDATES,
    CandidateRecord,
    Origin,
    PolicyRun,
    ScriptedRun,
)
from regen.falsify.space import candidate_id, canonical
from regen.runfolder import RunFolder, RunManifest, RunSettings, ScenarioFolder, now, read_model
from regen.whatif import Edit, apply_edits

if TYPE_CHECKING:
    from regen.assets.database import AssetDatabase
    from regen.core.graph import CausePath
    from regen.core.scenario import Scenario
    from regen.core.verdict import Verdict
    from regen.harness.cases import CaseResult
    from regen.harness.contract import PolicyHarness


@dataclass
class Source:
    """A verified scenario of the run the search starts from."""

    name: str  # its folder name in the run
    folder: Path
    scenario: Scenario
    path: CausePath
    verdict: Verdict

    @property
    def seed(self) -> int:
        """The seed the scenario was grounded with (a candidate keeps it: only the edits differ)."""
        return int(self.scenario.world.get("seed", 0) or 0)

    @property
    def causal(self) -> str | None:
        return self.verdict.causal.status if self.verdict.causal is not None else None


@dataclass
class Bench:
    """What every candidate of one search shares."""

    out: Path  # OUT (absolute)
    harness: PolicyHarness
    db: AssetDatabase
    robot: tuple[str, ...]  # the robot's words (never an added cause's asset)
    policy: str
    oracle: str = "fsm"
    seed: int = 0  # added to each source's grounding seed
    pictures: bool = True  # the candidate's animation and the failure's GIF
    settings: dict[str, Any] = field(default_factory=dict)  # a kept candidate was tested with these
    domain_settings: dict[str, str | None] = field(default_factory=dict)  # the run's (run.json)
    on_note: Callable[[str], None] | None = None

    def run_folder(self, cid: str) -> Path:
        return self.out / CANDIDATES / cid

    def tests_folder(self, cid: str) -> Path:
        """Where ``regen test CANDIDATE --policy SPEC`` writes by default: the same folder, so the
        replay command reruns exactly these results."""
        from regen.harness.cli import default_out

        return default_out(self.run_folder(cid), self.policy)

    def rel(self, p: Path | None) -> str | None:
        return None if p is None else Path(p).relative_to(self.out).as_posix()


#: the words of the baseline candidate: the source scenario regrounded with no edit
NO_EDIT = "no edit (the scenario as generated)"

def replay_command(run: Path, policy: str, oracle: str) -> str:
    """The ``regen test`` command that runs the policy in a candidate again (a policy file's path
    made absolute, so the command works from any folder)."""
    spec = policy.strip()
    file_part, sep, attr = (spec, "", "") if spec.endswith(".py") else spec.rpartition(":")
    if file_part.endswith(".py"):
        spec = str(Path(file_part).expanduser().absolute()) + sep + attr
    extra = f" --oracle {oracle}" if oracle != "fsm" else ""
    return f"regen test {shlex.quote(str(run))} --policy {shlex.quote(spec)}{extra}"


def _manifest(bench: Bench, cid: str, path: CausePath, words: list[str], source: str, seed: int) -> RunManifest:
    return RunManifest(behavior=path.behavior, settings=RunSettings(llm="none", max_scenarios=1, seed=seed,
                                                                    pictures=bench.pictures),
                       domain_settings=dict(bench.domain_settings), status="done", started=now(),
                       finished=now(), scenarios=[cid],
                       message=f"a candidate of regen falsify: {source} with {'; '.join(words)}")


def kept(bench: Bench, cid: str) -> CandidateRecord | None:
    """The candidate as an earlier run of the same search finished it: its record was made with
    the same settings, its scenario folder is unchanged since (its digest) and, where the policy
    ran, its tests.json is there. A candidate that could not be run is run again."""
    run = bench.run_folder(cid)
    got = read_model(run / CANDIDATE_JSON, CandidateRecord)
    if not got.ok:
        return None
    rec: CandidateRecord = got.value
    if rec.settings != bench.settings or rec.status == "error":
        return None
    if rec.scripted.status != "not_applied" and ScenarioFolder(run / RunFolder.SCENARIOS / cid).digest() != rec.digest:
        return None
    if rec.policy is not None and not (bench.tests_folder(cid) / RunFolder.TESTS_JSON).is_file():
        return None
    return rec.model_copy(update={"kept": True})


def run_candidate(bench: Bench, source: Source, edits: Sequence[Edit], *, origin: Origin = "single",
                  by_model: bool = False) -> CandidateRecord:
    """Build, simulate and test one candidate (see the module docstring); its record is also
    written to ``candidate.json``."""
    edits = canonical(edits)
    cid = candidate_id(source.name, edits)
    run = bench.run_folder(cid)
    words = [e.describe() for e in edits] or [NO_EDIT]
    base = {"cid": cid, "scenario": source.name, "edits": edits, "words": words, "origin": origin,
            "by_model": by_model, "folder": bench.rel(run), "settings": bench.settings}
    t0 = time.perf_counter()
    try:
        path = apply_edits(source.scenario, source.path, list(edits), bench.db, robot=bench.robot)
    except ConfigError as exc:
        rec = CandidateRecord(**base, status="invalid", reason=f"the edits do not apply: {exc}", simulated=False,
                              scripted=ScriptedRun(status="not_applied", reason=str(exc)))
        return _written(run, rec)
    seed = source.seed + bench.seed
    sf = ScenarioFolder(run / RunFolder.SCENARIOS / cid)
    verdict = _grounded(bench, sf, path, seed)
    write_json(run / RunFolder.MANIFEST, _manifest(bench, cid, path, words, source.name, seed))
    scripted = ScriptedRun(status=verdict.status, verified=verdict.feasible,
                           causal=verdict.causal.status if verdict.causal is not None else None,
                           reason=verdict.reason)
    base.update(scenario_folder=bench.rel(sf.path), xosc=bench.rel(next(iter(sorted(sf.path.glob("*.xosc"))), None)))
    simulated = (sf / sf.TRACE).is_file() or verdict.status == "simulation_failed"
    if not verdict.feasible:
        rec = CandidateRecord(**base, status="invalid", scripted=scripted, digest=sf.digest(), simulated=simulated,
                              reason=f"the scripted {bench.harness.robot} does not verify ({verdict.status}: "
                                     f"{verdict.reason}); the candidate tests nothing",
                              parameters=_numeric(sf.scenario()), wall=time.perf_counter() - t0)
        return _written(run, rec)
    case = _test(bench, run, cid)
    rec = _judged(bench, base, scripted, case, cid)
    rec.digest, rec.wall = sf.digest(), time.perf_counter() - t0
    return _written(run, rec)


def _grounded(bench: Bench, sf: ScenarioFolder, path: CausePath, seed: int) -> Verdict:
    """The candidate's scenario grounded, simulated and verified (rule grounding, no model), or
    the one an earlier run left in its folder for the same cause path and seed."""
    from regen.pipeline.stages import run_path

    earlier = read_model(sf.path.parent.parent / CANDIDATE_JSON, CandidateRecord).value
    verdict = sf.verdict()
    if verdict is not None and sf.holds(path) and earlier is not None and \
            earlier.settings.get("seed") == bench.settings.get("seed"):
        return verdict
    if sf.path.is_dir():
        sf.reset(grounding=True)
    return run_path(path, sf.path, llm=None, seed=seed, pictures=bench.pictures).verdict


def _test(bench: Bench, run: Path, cid: str) -> CaseResult | None:
    """The policy in the candidate, by regen test's own suite; its one case (None: none ran)."""
    from regen.harness.pictures import keep_failures
    from regen.harness.suite import run_tests

    dest = bench.tests_folder(cid)
    report = run_tests(run, bench.policy, variants=1, seed=bench.seed, oracle=bench.oracle, adversarial=True,
                       harness=bench.harness, out=dest, on_note=bench.on_note,
                       on_episode=keep_failures(dest, bench.harness, policy=bench.policy, pictures=bench.pictures))
    return report.cases[0] if report.cases else None


def _judged(bench: Bench, base: dict[str, Any], scripted: ScriptedRun, case: CaseResult | None,
            cid: str) -> CandidateRecord:
    """The record of a candidate whose scripted robot verified, from its test case."""
    from regen.harness.adversarial import failing
    from regen.harness.cases import SuiteReport

    if case is None:
        return CandidateRecord(**base, status="error", scripted=scripted, reason="no test case ran")
    dest = bench.tests_folder(cid)
    if case.template is not None:
        scripted.collision = case.template.collision
    stages = [" and ".join(s.conditions) for s in case.robot_stages if s.reached_at is None]
    policy = PolicyRun(status=case.status, cause=case.cause, message=case.message, collision=case.collision,
                       collision_with=case.collision_with, collision_time=case.collision_time,
                       min_ttc=case.min_ttc, min_distance=case.min_distance, infractions=list(case.infractions),
                       missed=stages[:1] if case.cause == "state_not_reached" else [],
                       gif=bench.rel(dest / case.gif) if case.gif else None)
    fields = {**base, "scripted": scripted, "policy": policy, "parameters": case.parameters,
              "tests": bench.rel(dest / RunFolder.TESTS_JSON)}
    if case.cause == "error":
        return CandidateRecord(**fields, status="error", reason=case.message)
    if case.status == "skipped":
        return CandidateRecord(**fields, status="invalid", reason=case.message)
    if case.status == "passed":
        return CandidateRecord(**fields, status="passed", reason=case.message or "the policy passed")
    if case.cause == "state_not_reached" and scripted.causal == "not_sufficient":
        # the world no longer calls for the behavior: the reference robot, which reacts to what it
        # perceives, does not show it either (a light set to green), so a missed state is no failure
        return CandidateRecord(**fields, status="invalid",
                               reason=f"the policy missed a state the edited world does not call for: the reference "
                                      f"{bench.harness.robot} does not show the behavior with this cause either "
                                      f"(not_sufficient); {case.message}")
    if failing(SuiteReport(run="", policy=bench.policy, cases=[case])):
        return CandidateRecord(**fields, status="failed", reason=case.message)
    return CandidateRecord(**fields, status="invalid",
                           reason=f"the scripted {bench.harness.robot} did not verify or collided: {case.message}")


def _numeric(scenario: Scenario | None) -> dict[str, dict[str, float]]:
    if scenario is None:
        return {}
    return {a: {k: float(v) for k, v in p.items() if isinstance(v, (int, float)) and not isinstance(v, bool)}
            for a, p in scenario.parameters.items()}


def _written(run: Path, rec: CandidateRecord) -> CandidateRecord:
    run.mkdir(parents=True, exist_ok=True)
    write_json(run / CANDIDATE_JSON, rec)
    return rec


__all__ = ["Bench", "Source", "kept", "replay_command", "run_candidate"]
