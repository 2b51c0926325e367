"""The main job, :func:`generate`: behavior -> graph -> paths -> ground -> simulate -> verify ->
export, into a run folder, resuming what an earlier invocation left.

:class:`MainJob` is one invocation on an opened run folder: one method per stage (:meth:`~MainJob.expand`,
:meth:`~MainJob.ground`, :meth:`~MainJob.simulate`, :meth:`~MainJob.report`), the state they share
(the manifest, the model client, the events file, the outcomes so far) on the object, and
:meth:`~MainJob.run` running them in order and recording how the run ended. The work on one cause
chain is the stage functions of :mod:`regen.pipeline.stages`; which paths run and their folder
names are :func:`select_paths` and :func:`folder_names`.
"""

from __future__ import annotations

import contextlib
import json
import logging
import threading
import time
from collections.abc import Callable, Collection
from concurrent.futures import Future
from pathlib import Path
from typing import Any

from regen import domains
from regen.contract import DomainBackend
from regen.core.behavior import Behavior
from regen.core.graph import CausePath, ScenarioGraph
from regen.core.io import cannot_write, storage_error, write_json
from regen.core.verdict import Verdict
from regen.errors import RegenError
from regen.expand.expansion import expand as expand_behavior
from regen.expand.run import draw_graph_files, save_graph
from regen.interrupts import Interrupts
from regen.llm.client import LLM
from regen.pipeline.stages import (
    ScenarioOutcome,
    ground_stage,
    needs_drawing,
    redraw_stage,
    simulate_stage,
)
from regen.pipeline.summary import Event, RunResult, finish
from regen.pipeline.tasks import ProcessTasks, ScenarioTasks, WorkerDied
from regen.promises.names import slug
from regen.promises.secrets import redact
from regen.runfolder import (
    RunFolder,
    RunManifest,
    RunSettings,
    ScenarioFolder,
    merge_usage,
    now,
)

log = logging.getLogger(__name__)


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
        with Interrupts() as interrupts:
            job = MainJob(run, manifest, backend, settings, interrupts, llm=llm, replay=replay, on_event=on_event)
            return job.run()
    finally:
        run.unlock()


WAIT_SLICE = 10.0  # [s] while a job waits for its turn at the model, run.json is updated this often


class _TurnAtModel:
    """A job's turn at the model (``model_gate``, a batch's one-at-a-time local model): taken at
    the job's first call that goes to the model, then held until the block ends (the job's
    expansion and grounding, whose calls then follow each other), so that a job whose answers
    are all cached (resumed, replayed) never waits behind another job's model calls. A gate that
    can be acquired with a timeout (a semaphore) is waited for in slices of :data:`WAIT_SLICE`,
    ``on_waiting`` told after each, so that a batch killed while a job waits keeps that wait."""

    def __init__(self, gate: Callable[[], contextlib.AbstractContextManager[Any]],
                 on_wait: Callable[[float, float], None] | None = None,
                 on_waiting: Callable[[float, float], None] | None = None):
        self._gate = gate
        self._held: contextlib.AbstractContextManager[Any] | None = None
        self._lock = threading.Lock()
        self._on_wait = on_wait  # (start, end) of the wait for the turn [perf_counter s]
        self._on_waiting = on_waiting  # (start, now) while it lasts

    def take(self) -> None:
        with self._lock:
            if self._held is None:
                start = time.perf_counter()
                held = self._gate()
                acquire = getattr(held, "acquire", None)
                if acquire is None:
                    held.__enter__()
                else:  # its __exit__ releases what this acquired
                    while not acquire(timeout=WAIT_SLICE):
                        if self._on_waiting is not None:
                            self._on_waiting(start, time.perf_counter())
                self._held = held
                if self._on_wait is not None:
                    self._on_wait(start, time.perf_counter())

    def __enter__(self) -> _TurnAtModel:
        return self

    def __exit__(self, *exc: object) -> None:
        with self._lock:
            held, self._held = self._held, None
        if held is not None:
            held.__exit__(None, None, None)


class MainJob:
    """One invocation of the main job on a run folder :meth:`RunFolder.open` has locked.

    Made, it has started: ``run.json`` written as the run resumes, ``events.jsonl`` open for
    appending, the model client made unless one was given (then its cache file is the run's, and
    it is closed at the end). :meth:`run` runs the stages and returns the :class:`RunResult`."""

    def __init__(self, run: RunFolder, manifest: RunManifest, backend: DomainBackend, settings: RunSettings,
                 interrupts: Interrupts, *, llm: LLM | None = None, replay: bool = False,
                 on_event: Callable[[Event], None] | None = None, tasks: ScenarioTasks | None = None,
                 model_gate: Callable[[], contextlib.AbstractContextManager[Any]] | None = None):
        self.run_folder, self.manifest, self.backend, self.settings = run, manifest, backend, settings
        self.interrupts = interrupts
        self.tasks = tasks  # where scenarios run (a batch's pool or Ray); None: --workers decides
        self.model_gate = model_gate or contextlib.nullcontext  # held while the model is asked
        self.failed: dict[str, str] = {}  # scenario -> why it has no verdict (its worker died)
        self.on_event = on_event
        self.behavior = manifest.behavior
        run.write_manifest(manifest)
        self.started = time.perf_counter()
        self.events = open(run / run.EVENTS, "a", encoding="utf-8")
        self.own_llm = llm is None  # made here: closed here (its cache file is the run's)
        self.llm = llm if llm is not None else LLM(
            settings.llm, cache=run.cache_path, replay=replay, timeout=settings.llm_timeout,
            on_call=lambda c: self.emit("llm_call", purpose=c.purpose, cached=c.cached,
                                        tokens=c.input_tokens + c.output_tokens))
        self.earlier_usage = dict(manifest.usage)  # of the invocations before this one
        self.outcomes: list[ScenarioOutcome] = []
        self.graph: ScenarioGraph | None = None
        self.graph_pictures: Future | None = None  # the graph's pictures drawn as a task (a batch)
        self.disk_full = False  # the run folder took no more (a full disk, a read-only folder)
        # the wait for the turn at the model (a batch; taken once per invocation): (start, end),
        # or (start, now) while it lasts
        self._wait: tuple[float, float] | None = None
        self._stage: tuple[str, float] | None = None  # the stage running, and when it was last credited
        self._timing = threading.RLock()

    # --- progress ----------------------------------------------------------------------------

    def emit(self, kind: str, **data: Any) -> None:
        """One progress event: appended to events.jsonl and given to ``on_event``."""
        ev = {"t": round(time.perf_counter() - self.started, 3), "event": kind, **data}
        self.events.write(json.dumps(ev, default=str) + "\n")
        self.events.flush()
        if self.on_event:
            self.on_event(ev)

    def begin(self, stage: str) -> None:
        """``stage`` runs from now; its time is credited as it goes (:meth:`credit`)."""
        with self._timing:
            self._stage = (stage, time.perf_counter())

    def credit(self) -> None:
        """Add the time since the running stage was last credited to its total in run.json (a
        resume adds to it), less the time the job waited for its turn at the model (a batch),
        which goes to ``model_wait``. As a stage ends, and while the job waits for the model."""
        with self._timing:
            if self._stage is None:
                return
            stage, t0 = self._stage
            end = time.perf_counter()
            a, b = self._wait or (end, end)
            waited = max(0.0, min(b, end) - max(a, t0))
            timings = self.manifest.timings
            timings[stage] = timings.get(stage, 0.0) + end - t0 - waited
            if waited > 0:
                timings["model_wait"] = timings.get("model_wait", 0.0) + waited
            self._stage = (stage, end)

    def end_stage(self) -> None:
        """The running stage's time credited; no stage runs."""
        with self._timing:
            self.credit()
            self._stage = None

    def waited(self, start: float, end: float) -> None:
        """The wait for the turn at the model ended."""
        with self._timing:
            self._wait = (start, end)

    def waiting(self, start: float, now: float) -> None:
        """Still waiting for the turn at the model: the wait so far credited and run.json
        written, so that a kill now keeps it (seen: a resumed behavior whose 620 s of waiting
        before the kill were in no figure of the batch's report)."""
        with self._timing:
            self._wait = (start, now)
            self.credit()
            self.checkpoint()

    # --- the stages --------------------------------------------------------------------------

    def run(self) -> RunResult:
        """Expand, ground, simulate; then how the run ended goes into run.json, whatever ended
        it (:meth:`close`): done, interrupted, a model error, or a disk that takes no more."""
        run, manifest = self.run_folder, self.manifest
        try:
            with _TurnAtModel(self.model_gate, on_wait=self.waited, on_waiting=self.waiting) as turn:
                self.llm.before_model = turn.take  # taken at the first call the cache cannot answer
                try:
                    paths = self.expand()
                    pending = self.ground(paths)
                finally:
                    self.llm.before_model = None
            self.simulate(pending)
            self.interrupts.check()
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
            self.disk_full = True
            raise error from None
        finally:
            self.close()
        return RunResult(run.path, manifest, self.graph, self.outcomes)

    def expand(self) -> list[CausePath]:
        """The cause graph (graph.json as it grows, then its pictures), and the cause paths to run,
        their folder names in run.json."""
        run, settings, backend = self.run_folder, self.settings, self.backend
        self.emit("stage", stage="expand")
        self.begin("expand")
        self.graph = graph = expand_behavior(
            self.behavior, self.llm, database=backend.database(), backend=backend, limits=settings.limits(),
            prior=settings.prior, candidates=settings.candidates, forced_causes=settings.forced_causes,
            on_update=lambda g, what: (write_json(run / run.GRAPH, g),
                                       self.emit("graph", step=what, nodes=len(g.nodes))))
        if graph.stop_reason and "interrupted" in graph.stop_reason:
            raise KeyboardInterrupt
        self.interrupts.check()
        if self.tasks is not None and settings.pictures:
            # a batch: the pictures are drawn by a worker while this process asks the model for
            # the next behavior; the report waits for them (:meth:`_graph_drawn`)
            save_graph(graph, run.path, pictures=False)
            self.graph_pictures = self.tasks.submit(draw_graph_files, str(Path(run.path).resolve()))
        else:
            save_graph(graph, run.path, pictures=settings.pictures)
        self.end_stage()
        insisted = {n.label for n in graph.events() if any(d.by == "user" for d in n.history)}
        paths = select_paths(graph.paths(), settings.max_scenarios, first=insisted)
        self.manifest.scenarios = folder_names(paths)
        self.checkpoint()
        self.emit("paths", total=len(paths), names=self.manifest.scenarios)
        return paths

    def ground(self, paths: list[CausePath]) -> list[str]:
        """Ground each cause path into its scenario folder; the names of those left to simulate
        (grounded now or by an earlier invocation). A finished scenario is kept (:meth:`keep`)."""
        self.emit("stage", stage="ground")
        self.begin("ground")
        pending: list[str] = []
        for i, (path, name) in enumerate(zip(paths, self.manifest.scenarios, strict=True)):
            folder = self.run_folder.scenario(name)
            if not folder.holds(path):  # made for another cause path, or never started
                folder.reset(grounding=True)
            done = folder.verdict()
            if done is not None:
                self.keep(name, folder, done)
                continue
            if folder.scenario() is not None:  # grounded in an earlier invocation
                pending.append(name)
                continue
            self.emit("grounding", name=name)
            verdict = ground_stage(self.backend, path, self.llm, folder, seed=self.settings.seed + i)
            self.credit()
            self.checkpoint()  # a kill during the next grounding keeps this one's time and calls
            self.interrupts.check()
            if verdict is None:
                pending.append(name)
            else:
                self.outcomes.append(ScenarioOutcome(name, verdict, path=folder.path))
                self.emit("scenario_done", name=name, feasible=False, status=verdict.status, reason=verdict.reason)
        self.end_stage()
        self.checkpoint()
        return pending

    def checkpoint(self) -> None:
        """The stage times and model usage so far into run.json, so that a run killed after a
        stage (kill -9, a lost machine) keeps them; a resume adds to them (:attr:`earlier_usage`
        is what run.json held when this invocation began)."""
        with self._timing:
            self.manifest.usage_last = self.llm.stats.as_dict()
            self.manifest.usage = merge_usage(self.earlier_usage, self.manifest.usage_last)
            self.run_folder.write_manifest(self.manifest)

    def keep(self, name: str, folder: ScenarioFolder, done: Verdict) -> None:
        """A scenario an earlier invocation finished: its outcome, its missing pictures or exports
        drawn again first (a first Ctrl-C lets the drawing finish)."""
        if needs_drawing(folder, done, self.settings.pictures):
            self.emit("redrawing", name=name)
            with self.interrupts.deferred():
                redraw_stage(self.behavior.domain, str(folder.path), self.settings.pictures,
                             self.settings.export_options)
            self.interrupts.check()
        self.outcomes.append(ScenarioOutcome(name, done, skipped=True, path=folder.path))
        self.emit("scenario_done", name=name, feasible=done.feasible, status=done.status, skipped=True)

    def simulate(self, pending: list[str]) -> None:
        """Simulate, verify, draw and export each grounded scenario (:func:`simulate_stage`): as
        tasks (the batch's, or worker processes when the settings ask for more than one and more
        than one is pending), else here."""
        self.emit("stage", stage="simulate", total=len(pending))
        self.begin("simulate")
        dirs = {name: str(self.run_folder.scenario(name).path) for name in pending}
        if self.tasks is not None and dirs:
            self.simulate_as_tasks(self.tasks, dirs)
        elif self.settings.workers > 1 and len(pending) > 1:
            tasks = ProcessTasks(min(self.settings.workers, len(pending)))
            try:
                self.simulate_as_tasks(tasks, dirs)
            except BaseException:
                tasks.close(cancel=True)  # running scenarios finish and are kept
                raise
            tasks.close()
        else:
            self.simulate_here(dirs)
        self.end_stage()

    def simulate_as_tasks(self, tasks: ScenarioTasks, dirs: dict[str, str]) -> None:
        """The scenarios of ``dirs`` (name -> folder) as ``tasks``, collected in run order. One
        whose worker died on every attempt has no verdict: its outcome says so (a rerun runs it
        again) and :attr:`failed` keeps the reason."""
        domain, pictures, options = self.behavior.domain, self.settings.pictures, self.settings.export_options
        futs = {name: tasks.submit(simulate_stage, domain, str(Path(folder).resolve()), pictures, options)  # a worker's
                for name, folder in dirs.items()}  # working folder may differ (Ray)
        try:
            for name, fut in futs.items():
                while True:
                    try:
                        res = fut.result(timeout=0.5)
                        break
                    except TimeoutError:
                        self.interrupts.check()
                    except WorkerDied as exc:
                        res = None
                        self.worker_died(name, dirs[name], str(exc))
                        break
                if res is not None:
                    self.collect(name, dirs[name], res)
                self.interrupts.check()
        except BaseException:
            for fut in futs.values():
                fut.cancel()
            raise

    def worker_died(self, name: str, folder: str, why: str) -> None:
        """A scenario whose worker died on each attempt: an outcome without a verdict on disk."""
        self.failed[name] = why
        verdict = Verdict(feasible=False, status="simulation_failed",
                          reason=f"not simulated: {why}; run the same command again to retry it")
        self.outcomes.append(ScenarioOutcome(name, verdict, path=Path(folder)))
        self.emit("scenario_done", name=name, feasible=False, status=verdict.status, reason=verdict.reason)

    def simulate_here(self, dirs: dict[str, str]) -> None:
        """The scenarios of ``dirs`` (name -> folder) one after the other in this process; a first
        Ctrl-C lets the current one finish (kept), then the run stops."""
        for name, folder in dirs.items():
            self.emit("simulating", name=name)
            with self.interrupts.deferred():
                done = simulate_stage(self.behavior.domain, folder, self.settings.pictures,
                                      self.settings.export_options)
            self.collect(name, folder, done)
            self.interrupts.check()

    def collect(self, name: str, folder: str, res: dict[str, Any]) -> None:
        """The outcome of one simulated scenario (:func:`simulate_stage`'s plain data); the
        stage's time so far into run.json, so that a kill before the stage ends keeps it (seen:
        a batch killed after a behavior's scenarios were simulated showed its simulation as 0 s)."""
        verdict = Verdict.model_validate(res["verdict"])
        self.outcomes.append(ScenarioOutcome(name, verdict, timings=res["timings"], path=Path(folder)))
        self.credit()
        self.checkpoint()
        self.emit("scenario_done", name=name, feasible=verdict.feasible, status=verdict.status,
                  reason=verdict.reason)

    def report(self) -> None:
        """summary.json and report.html, then run.json (:func:`regen.pipeline.summary.finish`)."""
        finish(self.run_folder, self.manifest, self.outcomes, self.emit)

    # --- the end -----------------------------------------------------------------------------

    def _graph_drawn(self) -> None:
        """Wait for the graph's pictures a task draws; where that task failed (its worker died,
        the batch was stopped), draw them here: the report never goes without them."""
        fut, self.graph_pictures = self.graph_pictures, None
        if fut is None or self.graph is None:
            return
        try:
            fut.result()
        except Exception as exc:  # noqa: BLE001 (any failure of the task: drawn here instead)
            log.warning("the graph's pictures were not drawn by the worker (%s); drawing them here", exc)
            save_graph(self.graph, self.run_folder.path, pictures=True)

    def close(self) -> None:
        """How the run ended, into run.json: the model usage, the outcomes in run order, and the
        summary and report when there is a graph (:meth:`report`); after a disk that took no more,
        run.json only (the summary and report wait for the resume). Then the events file and the
        model client this job made are closed."""
        run, manifest = self.run_folder, self.manifest
        manifest.usage_last = self.llm.stats.as_dict()
        manifest.usage = merge_usage(self.earlier_usage, manifest.usage_last)
        manifest.finished = now()
        order = {n: i for i, n in enumerate(manifest.scenarios)}
        self.outcomes.sort(key=lambda o: order.get(o.folder, 1 << 30))
        try:
            if self.disk_full:  # say so in run.json; the summary and report wait for the resume
                run.record_failure(manifest)
            elif self.graph is not None:
                self._graph_drawn()
                self.report()
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
                self.events.close()
            if self.own_llm:
                self.llm.cache.close()


__all__ = ["MainJob", "folder_names", "generate", "select_paths"]
