"""The main job: behavior -> graph -> paths -> ground -> simulate -> verify -> export.

The stage functions (:mod:`regen.pipeline.stages`) are the only route from a behavior to a
verdict: ``regen generate``, :func:`generate`, :func:`run_path` (one cause chain, for tests,
benchmarks and library users) and the worker processes all call them. Everything goes into a
run folder (:mod:`regen.runfolder`); rerunning the same command resumes: finished scenarios are
skipped and model answers come from the run's cache, so nothing already computed is done again.

Error policy: a model error that retrying later can fix (replay miss, provider unreachable,
missing key, bad model file) stops the run with its message; the run stays resumable and no
verdict is written for the scenario it hit. So does a disk that takes no more (full, read-only):
one line that says so (exit 2), ``run.json`` "failed", and the resume redoes what is missing,
pictures included. A cause chain that cannot be grounded, an unsatisfiable placement, an
invalid FSM or a simulator failure is that scenario's verdict.
"""

from __future__ import annotations

import contextlib
import json
import logging
import os
import time
from collections.abc import Callable, Collection
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from regen import domains
from regen.contract import DomainBackend
from regen.core.behavior import Behavior
from regen.core.graph import CausePath, ScenarioGraph
from regen.core.io import cannot_write, storage_error, write_json
from regen.core.verdict import Verdict
from regen.errors import RegenError
from regen.expand.expansion import expand
from regen.expand.run import save_graph
from regen.interrupts import Interrupts
from regen.llm.client import LLM
from regen.pipeline.stages import (
    ScenarioOutcome,
    ground_stage,
    needs_drawing,
    redraw_stage,
    run_path,
    simulate_stage,
)
from regen.promises.names import slug
from regen.promises.secrets import redact
from regen.runfolder import (
    RunFolder,
    RunManifest,
    RunSettings,
    merge_usage,
    now,
)

log = logging.getLogger(__name__)

Event = dict[str, Any]
Emit = Callable[..., None]




@dataclass
class RunResult:
    run_dir: Path
    manifest: RunManifest
    graph: ScenarioGraph | None
    outcomes: list[ScenarioOutcome]

    @property
    def feasible(self) -> int:
        return sum(o.verdict.feasible for o in self.outcomes)


def select_paths(paths: list[CausePath], k: int, *, first: Collection[str] = ()) -> list[CausePath]:
    """Up to ``k`` paths: the causes in ``first`` (given with ``--cause``) before all others,
    whatever ``k``; then one per root cause (diversity across causes), then property variants
    of the same causes (same cause, different properties), in graph order."""
    variants = [p.variants() for p in paths]
    variants.sort(key=lambda v: v[0].events[0] not in first)  # stable: graph order otherwise
    firsts = [v[0] for v in variants]
    rest = [p for v in variants for p in v[1:]]
    seen: set[str] = set()
    ordered: list[CausePath] = []
    for p in firsts:
        (rest if p.events[0] in seen else ordered).append(p)
        seen.add(p.events[0])
    return (ordered + rest)[:k]


def folder_names(paths: list[CausePath]) -> list[str]:
    """Scenario folder names from the model's cause texts: slugged (:mod:`regen.promises.names`),
    made unique by their place in run order."""
    return [f"{i:02d}-{slug(p.events[0], fallback='scenario')}" for i, p in enumerate(paths, start=1)]




def _worker_init(parent: int) -> None:
    """In a simulation worker: die with the main process (a killed run leaves no worker behind,
    writing into its folder), and leave Ctrl-C to the main process, which stops the pool."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        PR_SET_PDEATHSIG = 1  # Linux prctl option
        libc.prctl(PR_SET_PDEATHSIG, signal.SIGKILL)
    except (OSError, AttributeError):  # not Linux: workers end when the pool's pipe closes
        pass
    import os

    if os.getppid() != parent:  # the main process died before prctl took effect
        os._exit(1)




# --- the main job --------------------------------------------------------------------------------


def generate(behavior: Behavior, out: Path, *, settings: RunSettings | None = None, llm: LLM | None = None,
             replay: bool = False, fresh: bool = False,
             on_event: Callable[[Event], None] | None = None) -> RunResult:
    """Run the whole pipeline into ``out`` (resuming what an earlier run left).

    Args:
        behavior: the robot behavior and its domain.
        out: the run folder.
        settings: limits, model string, seed, workers.
        llm: a model client (default: ``settings.llm`` with the run's cache file).
        replay: forbid model calls; every answer must be in the run's cache.
        fresh: discard an earlier run in ``out`` (its model cache is kept) instead of resuming.
        on_event: called with progress events (also appended to events.jsonl).
    """
    settings = settings or RunSettings()
    backend = domains.make(behavior.domain)
    backend.check_behavior(behavior)
    run = RunFolder(out)
    manifest = run.open(behavior, settings, backend.settings_key(behavior), fresh=fresh)
    try:
        return _run(run, manifest, backend, settings, llm, replay, on_event)
    finally:
        run.unlock()


def _run(run: RunFolder, manifest: RunManifest, backend: DomainBackend, settings: RunSettings,
         llm: LLM | None, replay: bool, on_event: Callable[[Event], None] | None) -> RunResult:
    with Interrupts() as interrupts:
        return _stages(run, manifest, backend, settings, llm, replay, on_event, interrupts)


def _stages(run: RunFolder, manifest: RunManifest, backend: DomainBackend, settings: RunSettings,
            llm: LLM | None, replay: bool, on_event: Callable[[Event], None] | None,
            interrupts: Interrupts) -> RunResult:
    run.write_manifest(manifest)
    started = time.perf_counter()
    events = open(run / run.EVENTS, "a", encoding="utf-8")

    def emit(kind: str, **data: Any) -> None:
        ev = {"t": round(time.perf_counter() - started, 3), "event": kind, **data}
        events.write(json.dumps(ev, default=str) + "\n")
        events.flush()
        if on_event:
            on_event(ev)

    own_llm = llm is None  # made here: closed here (its cache file is the run's)
    if llm is None:
        llm = LLM(settings.llm, cache=run.cache_path, replay=replay, timeout=settings.llm_timeout,
                  on_call=lambda c: emit("llm_call", purpose=c.purpose, cached=c.cached,
                                         tokens=c.input_tokens + c.output_tokens))
    behavior = manifest.behavior
    earlier_usage = dict(manifest.usage)  # of the invocations before this one
    outcomes: list[ScenarioOutcome] = []
    graph: ScenarioGraph | None = None
    disk_full = False  # the run folder took no more (a full disk, a read-only folder)

    def timed(stage: str, t0: float) -> None:
        manifest.timings[stage] = manifest.timings.get(stage, 0.0) + time.perf_counter() - t0

    try:
        emit("stage", stage="expand")
        t0 = time.perf_counter()
        graph = expand(behavior, llm, database=backend.database(), backend=backend, limits=settings.limits(),
                       prior=settings.prior, candidates=settings.candidates,
                       forced_causes=settings.forced_causes,
                       on_update=lambda g, what: (write_json(run / run.GRAPH, g),
                                                  emit("graph", step=what, nodes=len(g.nodes))))
        if graph.stop_reason and "interrupted" in graph.stop_reason:
            raise KeyboardInterrupt
        interrupts.check()
        save_graph(graph, run.path, pictures=settings.pictures)
        timed("expand", t0)
        insisted = {n.label for n in graph.events() if any(d.by == "user" for d in n.history)}
        paths = select_paths(graph.paths(), settings.max_scenarios, first=insisted)
        manifest.scenarios = folder_names(paths)
        run.write_manifest(manifest)
        emit("paths", total=len(paths), names=manifest.scenarios)

        emit("stage", stage="ground")
        t0 = time.perf_counter()
        pending: list[str] = []
        for i, (path, name) in enumerate(zip(paths, manifest.scenarios, strict=True)):
            folder = run.scenario(name)
            if not folder.holds(path):  # made for another cause path, or never started
                folder.reset(grounding=True)
            done = folder.verdict()
            if done is not None:
                if needs_drawing(folder, done, settings.pictures):
                    emit("redrawing", name=name)
                    with interrupts.deferred():
                        redraw_stage(behavior.domain, str(folder.path), settings.pictures)
                    interrupts.check()
                outcomes.append(ScenarioOutcome(name, done, skipped=True, path=folder.path))
                emit("scenario_done", name=name, feasible=done.feasible, status=done.status, skipped=True)
                continue
            if folder.scenario() is not None:  # grounded in an earlier invocation
                pending.append(name)
                continue
            emit("grounding", name=name)
            verdict = ground_stage(backend, path, llm, folder, seed=settings.seed + i)
            interrupts.check()
            if verdict is None:
                pending.append(name)
            else:
                outcomes.append(ScenarioOutcome(name, verdict, path=folder.path))
                emit("scenario_done", name=name, feasible=False, status=verdict.status, reason=verdict.reason)
        timed("ground", t0)

        emit("stage", stage="simulate", total=len(pending))
        t0 = time.perf_counter()
        dirs = {name: str(run.scenario(name).path) for name in pending}
        if settings.workers > 1 and len(pending) > 1:
            pool = ProcessPoolExecutor(max_workers=settings.workers, initializer=_worker_init,
                                       initargs=(os.getpid(),))
            try:
                futs = {name: pool.submit(simulate_stage, behavior.domain, dirs[name], settings.pictures)
                        for name in pending}
                for name, fut in futs.items():
                    _collect(outcomes, name, dirs[name], fut.result(), emit)
                    interrupts.check()
            except BaseException:
                pool.shutdown(wait=True, cancel_futures=True)  # running scenarios finish and are kept
                raise
            pool.shutdown()
        else:
            for name in pending:
                emit("simulating", name=name)
                with interrupts.deferred():
                    done = simulate_stage(behavior.domain, dirs[name], settings.pictures)
                _collect(outcomes, name, dirs[name], done, emit)
                interrupts.check()
        timed("simulate", t0)
        interrupts.check()
        manifest.status = "done"
    except KeyboardInterrupt:
        manifest.status = "interrupted"
        manifest.message = "interrupted; run the same command again to resume"
        raise
    except RegenError as exc:
        manifest.status = "failed"
        # redacted: run.json and the report keep it (a provider's error may echo a key)
        manifest.message = redact(f"{exc}; fix this and run the same command again to resume", credentials=False)
        raise
    except OSError as exc:
        if not cannot_write(exc, run.path):
            raise
        error = storage_error(exc, run.path)
        manifest.status, manifest.message = "failed", str(error)
        disk_full = True
        raise error from None
    finally:
        manifest.usage_last = llm.stats.as_dict()
        manifest.usage = merge_usage(earlier_usage, manifest.usage_last)
        manifest.finished = now()
        order = {n: i for i, n in enumerate(manifest.scenarios)}
        outcomes.sort(key=lambda o: order.get(o.folder, 1 << 30))
        try:
            if disk_full:  # say so in run.json; the summary and report wait for the resume
                run.record_failure(manifest)
            elif graph is not None:
                _finish(run, manifest, outcomes, emit)
            else:
                run.write_manifest(manifest)
        except OSError as exc:
            if not cannot_write(exc, run.path):
                raise
            error = storage_error(exc, run.path)
            manifest.status, manifest.message = "failed", str(error)
            run.record_failure(manifest)
            raise error from None
        finally:
            with contextlib.suppress(OSError):  # a full disk may refuse the last flush too
                events.close()
            if own_llm:
                llm.cache.close()
    return RunResult(run.path, manifest, graph, outcomes)


def _collect(outcomes: list[ScenarioOutcome], name: str, folder: str, res: dict[str, Any], emit: Emit) -> None:
    verdict = Verdict.model_validate(res["verdict"])
    outcomes.append(ScenarioOutcome(name, verdict, timings=res["timings"], path=Path(folder)))
    emit("scenario_done", name=name, feasible=verdict.feasible, status=verdict.status, reason=verdict.reason)


def summarize(manifest: RunManifest, outcomes: list[ScenarioOutcome]) -> dict[str, Any]:
    feasible = sum(o.verdict.feasible for o in outcomes)
    statuses: dict[str, int] = {}
    for o in outcomes:
        statuses[o.verdict.status] = statuses.get(o.verdict.status, 0) + 1
    return {"behavior": manifest.behavior.text, "domain": manifest.behavior.domain,
            "status": manifest.status, "scenarios": len(outcomes), "feasible": feasible,
            "success_rate": (feasible / len(outcomes)) if outcomes else 0.0, "statuses": statuses,
            "relaxed": sum(bool(o.verdict.relaxations) for o in outcomes),
            "with_fallbacks": sum(bool(o.verdict.fallbacks) for o in outcomes),
            "cause_not_shown": statuses.get("cause_not_shown", 0),
            "unfaithful": statuses.get("unfaithful", 0),
            "verified_fsm_source": _fsm_sources(outcomes),
            "timings": manifest.timings, "usage": manifest.usage.get("total", {})}


def _fsm_sources(outcomes: list[ScenarioOutcome]) -> dict[str, int]:
    """Who wrote the FSM of each feasible scenario: {'model': n, 'rules': n, 'model+rules': n}."""
    out: dict[str, int] = {}
    for o in outcomes:
        scenario = o.scenario() if o.verdict.feasible else None
        if scenario is not None:
            out[scenario.fsm_source] = out.get(scenario.fsm_source, 0) + 1
    return out


def _finish(run: RunFolder, manifest: RunManifest, outcomes: list[ScenarioOutcome], emit: Emit) -> None:
    """Summary and report first, the manifest last: 'done' is only said when all is on disk."""
    summary = summarize(manifest, outcomes)
    write_json(run / run.SUMMARY, summary)
    from regen.report import write_report

    t0 = time.perf_counter()
    try:
        write_report(run.path, manifest=manifest.model_dump(mode="json"))
    except Exception as exc:  # the report must never cost the run; say so where users look
        if cannot_write(exc, run.path):  # but a full disk stops the run (resumed later)
            raise
        log.warning("report failed: %s", exc, exc_info=True)
        manifest.message = (manifest.message + "; " if manifest.message else "") + f"report failed: {exc}"
    manifest.timings["report"] = time.perf_counter() - t0
    run.write_manifest(manifest)
    emit("finished", **{k: summary[k] for k in ("status", "scenarios", "feasible")})


__all__ = ["RunManifest", "RunResult", "RunSettings", "ScenarioOutcome", "generate", "ground_stage",
           "needs_drawing", "redraw_stage", "run_path", "select_paths", "simulate_stage"]
