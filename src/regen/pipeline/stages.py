"""The stages of one cause chain: ground, then simulate, verify, draw and export, into its
scenario folder (:class:`regen.runfolder.ScenarioFolder`); and the redrawing of a finished one
whose pictures or exports are missing. Plain functions over plain data, so worker processes run
them too; :func:`regen.pipeline.generate` and :func:`run_path` are their only callers.

Error policy: a model error that retrying later can fix (replay miss, provider unreachable,
missing key, bad model file) and a disk that takes no more (full, read-only) propagate: no
verdict is written, so a resume redoes exactly that work. A cause chain that cannot be
grounded, an unsatisfiable placement, an invalid FSM or a simulator failure is that scenario's
verdict; a picture or an export that fails for another reason is kept in ``error.txt``.
"""

from __future__ import annotations

import logging
import time
import traceback
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from regen import domains
from regen.contract import DomainBackend
from regen.core.graph import CausePath
from regen.core.io import cannot_write
from regen.core.scenario import Scenario
from regen.core.trace import Trace
from regen.core.verdict import Causal, Verdict
from regen.errors import LLMError, MalformedAnswerError, RegenError, UngroundableError
from regen.llm.client import LLM
from regen.runfolder import ScenarioFolder, read_json, read_model, read_text
from regen.verify import causal, claims, fidelity
from regen.verify.monitor import validate_fsm

log = logging.getLogger(__name__)


@dataclass
class ScenarioOutcome:
    folder: str  # the scenario folder's name
    verdict: Verdict
    skipped: bool = False  # finished in an earlier run
    timings: dict[str, float] = field(default_factory=dict)
    path: Path | None = None  # the scenario folder

    def scenario(self) -> Scenario | None:
        """The scenario as verified (its FSM relaxed where the verdict says so)."""
        return ScenarioFolder(self.path).scenario() if self.path else None

    def trace(self) -> Trace | None:
        return read_model(self.path / ScenarioFolder.TRACE, Trace).value if self.path else None


def _failed(status: str, reason: str, scenario: Scenario | None = None) -> Verdict:
    extra: dict[str, Any] = {}
    if scenario is not None:
        extra = {"conflicts": list(scenario.solver.conflicts),
                 "placement_relaxations": list(scenario.solver.relaxations),
                 "fallbacks": list(scenario.fallbacks)}
    return Verdict(feasible=False, status=status, reason=reason, **extra)  # type: ignore[arg-type]


def _fatal(exc: BaseException) -> bool:
    """Model errors that a later rerun can fix: they stop the run instead of becoming verdicts."""
    return isinstance(exc, LLMError) and not isinstance(exc, MalformedAnswerError)


# --- stage: ground -------------------------------------------------------------------------------


def _robot_names(backend: DomainBackend) -> tuple[str, ...]:
    return (backend.report_hints.robot, *backend.wording.robot_names)


def _model_fidelity(backend: DomainBackend, scenario: Scenario, llm: LLM) -> Scenario:
    """Where rules cannot tell whether the scenario shows its cause (its words name no asset),
    the model's yes/no answer, kept on the scenario for the verifier."""
    rules = fidelity.check_rules(scenario, backend.database(), robot=_robot_names(backend),
                                 own=backend.own_objects(scenario.behavior))
    if rules.status != "undecided":
        return scenario
    try:
        asked = fidelity.ask_model(scenario, llm, robot=backend.report_hints.robot)
    except KeyboardInterrupt:
        raise
    except Exception as exc:
        if _fatal(exc):
            raise
        log.warning("fidelity question for %s failed: %s", scenario.id, exc)
        return scenario
    return scenario.model_copy(update={"fidelity": asked})


def ground_stage(backend: DomainBackend, path: CausePath, llm: LLM | None, folder: ScenarioFolder, *,
                 seed: int = 0) -> Verdict | None:
    """Ground one cause path into ``folder``. Returns the verdict when the scenario ends here
    (not groundable, unsatisfiable, invalid FSM), else None: ready to simulate."""
    folder.start(path)
    t0 = time.perf_counter()
    try:
        scenario = backend.ground(path, llm, seed=seed)
    except KeyboardInterrupt:
        raise
    except Exception as exc:
        if _fatal(exc) or cannot_write(exc, folder.path):
            raise
        if not isinstance(exc, RegenError):  # a bug: keep the traceback; a reason is not one
            folder.write_error(traceback.format_exc())
        reason = str(exc) if isinstance(exc, RegenError) else f"{type(exc).__name__}: {exc}"
        # the graph's choice cannot be honored: said as such, never swapped for another choice
        verdict = _failed("ungroundable" if isinstance(exc, UngroundableError) else "grounding_failed", reason)
        folder.write_verdict(verdict)
        return verdict
    if llm is not None:
        scenario = _model_fidelity(backend, scenario, llm)
    folder.write_scenario(scenario, backend.config(scenario))
    folder.add_timings({"ground": time.perf_counter() - t0, "solve": scenario.solver.wall_time})
    status = scenario.solver.status
    if status in ("infeasible", "model_invalid"):
        verdict = _failed("unsatisfiable", "the constraints cannot all hold: "
                          + "; ".join(scenario.solver.conflicts), scenario)
    elif status == "unknown":
        verdict = _failed("unsatisfiable", "the solver found no placement within its time limit "
                          "(status unknown)", scenario)
    elif problems := validate_fsm(scenario.fsm, {e.name for e in scenario.entities}, scenario.domain):
        verdict = _failed("invalid_scenario", "; ".join(problems), scenario)
    else:
        return None
    folder.write_verdict(verdict)
    return verdict


# --- stage: simulate, verify, draw, export -------------------------------------------------------


def warm_stage(names: tuple[str, ...]) -> dict[str, float]:
    """In a process that has simulated nothing yet (a pool's zygote, a Ray worker): each
    domain's once-per-process work (:meth:`regen.contract.DomainBackend.warm`), seconds per
    domain."""
    return {name: domains.make(name).warm() for name in names}


def simulate_stage(domain: str, scenario_dir: str, pictures: bool = True,
                   export_options: dict[str, bool] | None = None) -> dict[str, Any]:
    """Simulate, verify, draw and export one grounded scenario folder. Runs in worker processes
    too, so it takes and returns plain data. The verdict is written once verified, before the
    pictures and exports are drawn (a kill while drawing leaves a verdict whose missing files a
    resume draws: :func:`needs_drawing`). ``export_options``: passed to the domain's export."""
    folder = ScenarioFolder(Path(scenario_dir))
    with folder.recording():  # what the domain writes here is the run's: --fresh removes it
        return _simulate(domain, folder, pictures, export_options or {})


def _simulate(domain: str, folder: ScenarioFolder, pictures: bool, export_options: dict[str, bool]
              ) -> dict[str, Any]:
    folder.reset()
    backend = domains.make(domain)
    scenario = folder.scenario()
    timings: dict[str, float] = {}
    if scenario is None:
        verdict = _failed("invalid_scenario", f"{folder / folder.SCENARIO} is missing or unreadable")
        folder.write_verdict(verdict)
        return {"verdict": verdict.model_dump(mode="json"), "timings": timings}
    try:
        t0 = time.perf_counter()
        sim = backend.simulate(scenario, folder.path)
        timings.update(sim.timings)  # the domain's own split (compile, simulate, record, ...)
        timings["simulate_total"] = time.perf_counter() - t0
        timings.setdefault("simulate", timings["simulate_total"])
        folder.write_trace(sim.trace)
        t0 = time.perf_counter()
        verdict, judged = backend.verify(scenario, sim.trace)
        rules = fidelity.check_rules(judged, backend.database(), robot=_robot_names(backend),
                                     own=backend.own_objects(judged.behavior), trace=sim.trace)
        verdict = fidelity.with_fidelity(verdict, fidelity.combine(rules, scenario.fidelity))
        timings["verify"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        verdict = verdict.model_copy(update={"causal": causal_stage(backend, judged, verdict, folder),
                                             "claims": narrative_claims(backend, judged, sim.trace)})
        timings["causal"] = time.perf_counter() - t0
    except KeyboardInterrupt:
        raise
    except Exception as exc:
        if cannot_write(exc, folder.path):  # not the scenario's fault: no verdict, redone on resume
            raise
        folder.write_error(traceback.format_exc())
        verdict = _failed("simulation_failed", str(exc) if isinstance(exc, RegenError)
                          else f"{type(exc).__name__}: {exc}", scenario)
        folder.add_timings(timings)
        folder.write_verdict(verdict)
        return {"verdict": verdict.model_dump(mode="json"), "timings": timings}
    if judged.fsm != scenario.fsm:  # relaxed: the folder shows the FSM the verdict is about
        folder.write_relaxed(judged, backend.config(judged))
    folder.add_files(dict(sim.files))
    folder.add_timings(timings)
    # the verdict before the pictures and exports: a run killed while drawing keeps it, and the
    # resume draws what is missing (needs_drawing: no render or export time recorded yet)
    folder.write_verdict(verdict)
    drawn, problems = _draw(backend, judged, sim.trace, verdict, folder, pictures, timings, export_options)
    if problems:
        folder.write_error("\n".join(problems))
    folder.add_files(drawn)
    folder.add_timings({k: timings[k] for k in ("render", "export") if k in timings})
    return {"verdict": verdict.model_dump(mode="json"), "timings": timings}


#: statuses whose FSM played out: the but-for check has something to check
_PLAYED_OUT = ("verified", "verified_after_relaxation", "unfaithful")


def narrative_claims(backend: DomainBackend, scenario: Scenario, trace: Trace) -> list[str]:
    """The narrative's sentences that claim a collision, a stop or a state the trace does not show."""
    robot = scenario.robot()
    track = trace.actors.get(robot.name) if robot is not None else None
    stood = bool(min(track.speed) < 0.5) if track is not None and track.speed else None
    harness = backend.policy_harness()
    collisions = None
    if harness is not None and robot is not None:
        collisions = [i.message for i in harness.incidents(scenario, trace) if i.collision]
    db = backend.database()
    cast = [(e.name, e.asset) for e in scenario.entities if not e.is_robot and e.asset in db.assets]
    shown: dict[str, dict[str, set[str]]] = {}
    for name, _ in cast:
        e, recorded = scenario.entity(name), trace.actors.get(name)
        shown[name] = {k: {str(v)} for k, v in e.properties.items()}
        for k, seq in (recorded.states.items() if recorded is not None else ()):
            shown[name].setdefault(k, set()).update(str(v) for v in seq)
    return (claims.check_narrative(scenario.narrative, collisions=collisions, robot_stood=stood,
                                   robot=backend.report_hints.robot)
            + claims.check_states(scenario.narrative, cast, shown, db))


def causal_stage(backend: DomainBackend, scenario: Scenario, verdict: Verdict, folder: ScenarioFolder
                 ) -> Causal:
    """Whether the scenario's cause causes its robot's behavior (:mod:`regen.verify.causal`):
    the domain's reference robot with and without the cause. A scenario whose FSM did not play
    out, or a domain without a reference robot, is ``not_checked`` with the reason; a failure of
    the check is ``not_checked`` with the failure (kept in error.txt), never the verdict's."""
    if verdict.status not in _PLAYED_OUT:
        return causal.not_checked(f"the scenario did not play out ({verdict.status}): no behavior to explain")
    graph = read_model(folder / folder.PATH, CausePath).value
    cause, others, how = causal.split_cast(
        scenario, backend.database(), robot=_robot_names(backend), own=backend.own_objects(scenario.behavior),
        graph_assets=[e.asset for e in graph.entities] if graph is not None else None)
    try:
        world = backend.reference_world(scenario, cause)
        return causal.but_for(world, cause, others, cause_from=how)
    except causal.NotCheckable as exc:
        return causal.not_checked(str(exc))
    except KeyboardInterrupt:
        raise
    except Exception as exc:
        if cannot_write(exc, folder.path):
            raise
        log.warning("the causal check of %s failed", folder.name, exc_info=True)
        folder.write_error(f"causal check failed:\n{traceback.format_exc()}")
        return causal.not_checked(f"the reference run failed: {type(exc).__name__}: {exc}")


def _draw(backend: DomainBackend, scenario: Scenario, trace: Trace, verdict: Verdict,
          folder: ScenarioFolder, pictures: bool, timings: dict[str, float],
          export_options: dict[str, bool] | None = None) -> tuple[dict[str, Path], list[str]]:
    """Pictures (when ``pictures``) and exports of a verified scenario: (role -> file, failures).
    A step's time lands in ``timings`` only when it succeeded (a resume redoes the others); a
    full disk or a read-only folder stops the run, anything else is kept in error.txt."""
    steps: list[tuple[str, Callable[[], dict[str, Path]]]] = [
        ("export", lambda: backend.export(scenario, folder.path, trace=trace, **(export_options or {})))]
    if pictures:
        steps.insert(0, ("render", lambda: backend.render(scenario, trace, verdict, folder.path)))
    files: dict[str, Path] = {}
    problems: list[str] = []
    for name, step in steps:
        t0 = time.perf_counter()
        try:  # a picture or an export is not worth the verdict; the failure is kept in error.txt
            files.update(step())
        except KeyboardInterrupt:
            raise
        except Exception as exc:
            if cannot_write(exc, folder.path):
                raise
            log.warning("%s of %s failed", name, folder.name, exc_info=True)
            problems.append(f"{name} failed:\n{traceback.format_exc()}")
            continue
        timings[name] = time.perf_counter() - t0
    return files, problems


#: How error.txt (older versions) says that a step met a full or read-only disk: worth redoing.
_DISK_WORDS = ("No space left", "Disk quota", "Read-only file system")


def _recorded_failure(folder: ScenarioFolder, step: str) -> str | None:
    """How error.txt says ``step`` failed: 'disk' (a full or read-only disk, as older versions
    recorded it: worth redoing), 'other' (a bug a redo would meet again), or None."""
    text = read_text(folder / folder.ERROR).value or ""
    _, found, after = text.partition(f"{step} failed:")
    if not found:
        return None
    return "disk" if any(w in after for w in _DISK_WORDS) else "other"


def needs_drawing(folder: ScenarioFolder, verdict: Verdict, pictures: bool) -> bool:
    """Whether a finished scenario lacks pictures or exports a resume should make: it has a
    trace, and a file it lists is gone, or a step met a full disk, or never succeeded (the run
    was made with --no-pictures) without failing for good."""
    if verdict.status == "simulation_failed" or not (folder / folder.TRACE).is_file():
        return False
    listed = read_json(folder / folder.FILES)
    if not listed.ok or not isinstance(listed.value, dict) or any(
            not isinstance(name, str) or Path(name).name != name or not (folder / name).is_file()
            for name in listed.value.values()):
        return True
    done = folder.timings()
    for step in ["export", "render"] if pictures else ["export"]:
        failure = _recorded_failure(folder, step)
        if failure == "disk" or (step not in done and failure is None):
            return True
    return False


def redraw_stage(domain: str, scenario_dir: str, pictures: bool = True,
                 export_options: dict[str, bool] | None = None) -> bool:
    """Draw and export a finished scenario again from its files (its verdict stays); False when
    they cannot be read (then nothing is written)."""
    folder = ScenarioFolder(Path(scenario_dir))
    scenario, verdict = folder.scenario(), folder.verdict()
    trace = read_model(folder / folder.TRACE, Trace).value
    if scenario is None or verdict is None or trace is None:
        return False
    timings: dict[str, float] = {}
    with folder.recording():
        drawn, problems = _draw(domains.make(domain), scenario, trace, verdict, folder, pictures, timings,
                                export_options)
    if problems:
        folder.write_error("\n".join(problems))
    else:
        (folder / folder.ERROR).unlink(missing_ok=True)
    folder.add_files(drawn)
    folder.add_timings(timings)
    return True


def run_path(path: CausePath, folder: str | Path, *, llm: LLM | None = None, seed: int = 0,
             pictures: bool = True) -> ScenarioOutcome:
    """Ground, simulate and verify one cause path into ``folder`` with the main job's stages
    (``llm=None``: the domain's rule-based grounding)."""
    sf = ScenarioFolder(Path(folder))
    backend = domains.make(path.behavior.domain)
    verdict = ground_stage(backend, path, llm, sf, seed=seed)
    if verdict is None:
        verdict = Verdict.model_validate(simulate_stage(path.behavior.domain, str(sf.path), pictures)["verdict"])
    return ScenarioOutcome(sf.name, verdict, timings=sf.timings(), path=sf.path)


__all__ = ["ScenarioOutcome", "ground_stage", "needs_drawing", "redraw_stage", "run_path", "simulate_stage", "warm_stage"]
