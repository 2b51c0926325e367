"""``regen batch``: many behaviors from one spec, each into the usual run folder under ``DIR``.

Each behavior is one :class:`~regen.pipeline.run.MainJob`, exactly the job ``regen generate``
runs, in a thread of its own. What differs is only where the work goes:

- model calls (expansion, grounding) stay in this process, under one limit per provider
  (:data:`MODEL_LIMITS`: the offline model answers one call at a time; a remote provider up to
  four behaviors at once);
- simulation, verification, the causal check, drawing and exports are tasks
  (:func:`~regen.pipeline.stages.simulate_stage`) on one shared pool: worker processes of this
  machine, or Ray tasks on a cluster with ``--ray``, so one behavior's scenarios simulate while
  the next one asks the model.

``DIR/batch.json`` (:class:`BatchRecord`) says what the batch is and how far it got; the summary
and report over all behaviors (:mod:`regen.batch.summary`) are written whenever the batch stops.
Running the same command again resumes: each run folder resumes as ``regen generate`` would, and
a scenario whose worker died twice (recorded in ``failed_scenarios``) is tried again.
"""

from __future__ import annotations

import contextlib
import logging
import os
import threading
import time
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from pathlib import Path
from typing import Any

from pydantic import Field, ValidationError

from regen import domains
from regen.batch.spec import PlannedBehavior, plan, read_spec
from regen.batch.summary import (
    BATCH_FILE,
    REPORT_FILE,
    SUMMARY_FILE,
    summarize_batch,
    write_batch_report,
)
from regen.core.base import Model
from regen.core.io import write_json
from regen.errors import ConfigError, RegenError, RunError
from regen.interrupts import Interrupts
from regen.pipeline.request import behavior_to_generate, export_options
from regen.pipeline.run import MainJob
from regen.pipeline.stages import warm_stage
from regen.pipeline.tasks import ProcessTasks, RayTasks, ScenarioTasks
from regen.promises.folders import entries, foreign_error, output_folder
from regen.promises.names import slug
from regen.promises.secrets import redact
from regen.runfolder import RunFolder, now, read_json

log = logging.getLogger(__name__)

#: the batch's own top-level files (``--fresh`` removes them, with what each run wrote)
BATCH_FILES = (BATCH_FILE, SUMMARY_FILE, REPORT_FILE)
#: behaviors asking one provider's model at once: the offline model (one process, one model in
#: memory) answers one call at a time; a remote provider takes a few
MODEL_LIMITS = {"local": 1}
REMOTE_LIMIT = 4
SAVE_EVERY = 30.0  # [s] batch.json is saved at least this often while behaviors run (wall time kept)


class BehaviorRecord(Model):
    """One behavior of ``batch.json``."""

    folder: str
    text: str
    domain: str
    scenarios: int
    status: str = "pending"  # pending, running, done, failed, interrupted
    message: str = ""
    failed_scenarios: dict[str, str] = Field(default_factory=dict)  # scenario -> why it has no verdict
    wall_seconds: float = 0.0  # over every invocation
    #: ``--fill-coverage``: the spec behavior's folder this run adds coverage to, the cause it
    #: insists on and the typology classes (ids) that cause presents; None for a spec entry
    fill_of: str | None = None
    fill_cause: str | None = None
    fill_classes: list[str] = Field(default_factory=list)


class BatchRecord(Model):
    """``DIR/batch.json``."""

    version: int = 1
    spec_file: str
    spec_sha256: str
    executor: str = "pool"  # pool or ray
    workers: int = 1
    ray_address: str | None = None
    started: str = ""
    finished: str | None = None
    status: str = "running"  # running, done, failed, interrupted
    message: str = ""
    wall_seconds: float = 0.0  # over every invocation
    behaviors: list[BehaviorRecord] = Field(default_factory=list)


def folder_names(planned: list[PlannedBehavior]) -> list[str]:
    """Run folder names: the place in the spec, then the behavior's text slugged."""
    width = max(2, len(str(len(planned))))
    return [f"{i:0{width}d}-{slug(p.behavior.text, fallback='behavior')}" for i, p in enumerate(planned, start=1)]


def model_gates(planned: list[PlannedBehavior]) -> dict[str, threading.Semaphore]:
    """One semaphore per provider the batch's behaviors use (:data:`MODEL_LIMITS`)."""
    providers = {p.settings.llm.split(":", 1)[0] for p in planned}
    return {name: threading.Semaphore(MODEL_LIMITS.get(name, REMOTE_LIMIT)) for name in providers}


def open_batch(out: Path, spec_file: Path, sha: str, names: list[str], planned: list[PlannedBehavior],
               *, fresh: bool) -> BatchRecord:
    """``batch.json`` of ``out``: the earlier one of the same spec (resumed), or a new one. A folder
    holding another spec's batch, or anything a batch does not write, is refused (nothing removed)."""
    out = output_folder(out)
    old = _earlier(out / BATCH_FILE)
    ours = set(BATCH_FILES) | set(names) | ({b.folder for b in old.behaviors} if old else set())
    foreign = [p.name for p in entries(out) if p.name not in ours and not p.name.startswith(".")]
    if foreign:
        raise foreign_error(out, foreign, doing="regen batch", writer="a batch")
    if old is not None and old.spec_sha256 != sha and not fresh:
        raise RunError(f"{out} holds a batch of another spec ({old.spec_file}); rerun with that spec to resume "
                       "it, add --fresh to start this one over it (model caches are kept), or choose another --out")
    if fresh:
        for name in BATCH_FILES:
            (out / name).unlink(missing_ok=True)
        old = None
    kept = {b.folder: b for b in old.behaviors} if old else {}
    behaviors = [kept.get(n) or BehaviorRecord(folder=n, text=p.behavior.text, domain=p.behavior.domain,
                                               scenarios=p.settings.max_scenarios)
                 for n, p in zip(names, planned, strict=True)]
    # runs an earlier --fill-coverage made stay recorded (their folders are the batch's own)
    behaviors += [b for b in (old.behaviors if old else []) if b.fill_of and b.folder not in names]
    return BatchRecord(spec_file=str(spec_file), spec_sha256=sha, started=old.started if old else now(),
                       wall_seconds=old.wall_seconds if old else 0.0, behaviors=behaviors)


def _earlier(path: Path) -> BatchRecord | None:
    """The batch.json an earlier invocation wrote, or None; RunError for one that cannot be read."""
    if not path.exists():
        return None
    got = read_json(path)
    try:
        return BatchRecord.model_validate(got.value)
    except ValidationError:
        raise RunError(f"{path} is not a batch record ({got.problem or 'unexpected content'}); remove it, "
                       "or choose another --out") from None


class BatchJob:
    """One invocation of a batch: the planned behaviors, the shared task pool, the record."""

    def __init__(self, out: Path, record: BatchRecord, planned: list[PlannedBehavior], tasks: ScenarioTasks,
                 interrupts: Interrupts, *, replay: bool = False, fresh: bool = False,
                 on_event: Callable[[dict[str, Any]], None] | None = None, fill_coverage: bool = False):
        self.out, self.record, self.tasks = out, record, tasks
        # the record's behavior i runs planned[i] (fill runs are added to both after the spec's ran;
        # fill records an earlier invocation made follow the spec's in the record, not run)
        self.planned = list(planned)
        self.interrupts, self.replay, self.fresh = interrupts, replay, fresh
        self.fill_coverage = fill_coverage
        self.on_event = on_event
        self.gates = model_gates(planned)
        self.lock = threading.Lock()
        self.started = time.perf_counter()
        # wall time is credited to batch.json at every save, so a batch killed with -9 keeps the
        # time of the invocation up to its last save (the resumed one adds its own)
        self._mark = self.started
        self._running: dict[int, float] = {}  # behavior index -> when its time was last credited

    def emit(self, kind: str, **data: Any) -> None:
        if self.on_event is not None:
            with self.lock:
                self.on_event({"t": round(time.perf_counter() - self.started, 3), "event": kind, **data})
        if kind == "scenario_done":  # finished work is on disk: its wall time goes there too
            self.save()

    def save(self) -> None:
        """batch.json as it stands, the wall time since the last save credited to the batch and
        to each running behavior."""
        with self.lock:
            now = time.perf_counter()
            self.record.wall_seconds += now - self._mark
            self._mark = now
            for i, since in self._running.items():
                self.record.behaviors[i].wall_seconds += now - since
                self._running[i] = now
            write_json(self.out / BATCH_FILE, self.record)

    def run(self) -> BatchRecord:
        """Every behavior in a thread (model calls gated per provider), their scenarios as tasks;
        with ``fill_coverage``, then the fill runs (:mod:`regen.batch.fill`); how the batch ended
        into batch.json, then the summary and report."""
        self.record.status, self.record.finished = "running", None
        self.save()
        self.emit("batch", total=len(self.planned), workers=self.tasks.workers,
                  names=[b.folder for b in self.record.behaviors[:len(self.planned)]])
        try:
            self.warm_workers()
            self.run_behaviors(range(len(self.planned)))
            if self.fill_coverage and not self.interrupts.seen:
                self.run_behaviors(self.add_fill())
        except KeyboardInterrupt:
            self.interrupts.seen = True  # every behavior stops at its next check, keeping what it has
            self.record.status = "interrupted"
            self.record.message = "interrupted; run the same command again to resume"
            raise
        finally:
            self.end()
        return self.record

    def warm_workers(self) -> None:
        """The simulators of the behaviors still to run loaded ahead of their scenarios, while
        their causes are expanded (:func:`~regen.pipeline.stages.warm_stage`): once, in the
        pool's zygote, which forks the workers with them loaded; on Ray, by each worker. A fresh
        worker's first scenario took 1.7 s more than the next ones (driving, measured)."""
        names = sorted({p.behavior.domain for i, p in enumerate(self.planned)
                        if self.record.behaviors[i].status != "done"})
        if names:
            self.tasks.warm(warm_stage, tuple(names))

    def run_behaviors(self, indices: range) -> None:
        """The behaviors ``indices`` of :attr:`planned`, each in a thread, until all ended."""
        if not indices:
            return
        threads = ThreadPoolExecutor(max_workers=min(len(indices), 32), thread_name_prefix="regen-behavior")
        try:
            futs: list[Future] = [threads.submit(self.behavior, i) for i in indices]
            for f in futs:
                while True:
                    try:
                        f.result(timeout=0.5)
                        break
                    except TimeoutError:
                        if time.perf_counter() - self._mark >= SAVE_EVERY:
                            self.save()
                        continue
        finally:
            threads.shutdown(wait=True, cancel_futures=True)

    def add_fill(self) -> range:
        """Plan the fill runs of the behaviors that are done (:func:`~regen.batch.fill.plan_fill`),
        add them to :attr:`planned` and the record (a fill record kept from an earlier invocation
        is reused, wall time and all) and return their indices."""
        from regen.batch.fill import plan_fill

        n = len(self.planned)
        spec = self.record.behaviors[:n]
        done = {b.folder for b in spec if b.status == "done"}
        fills = plan_fill(self.out, self.planned, [b.folder for b in spec], done)
        kept = {b.folder: b for b in self.record.behaviors[n:]}
        added = []
        for fill, p in fills:
            rec = kept.pop(fill.folder, None) or BehaviorRecord(
                folder=fill.folder, text=p.behavior.text, domain=p.behavior.domain, scenarios=1)
            rec.fill_of, rec.fill_cause, rec.fill_classes = fill.fill_of, fill.cause, fill.classes
            added.append(rec)
            self.planned.append(p)
        with self.lock:
            self.record.behaviors = spec + added + list(kept.values())
        self.save()
        self.emit("fill", runs=[r.folder for r in added])
        return range(n, n + len(added))

    def behavior(self, i: int) -> None:
        """One behavior's main job, start to end; its failure is its own (the others go on)."""
        p, rec = self.planned[i], self.record.behaviors[i]
        if self.interrupts.seen:
            return
        rec.status, rec.message = "running", ""
        with self.lock:
            self._running[i] = time.perf_counter()
        self.save()
        self.emit("behavior_started", behavior=rec.folder, text=rec.text)
        gate = self.gates[p.settings.llm.split(":", 1)[0]]
        try:
            job = self.open_job(p, rec, gate)
            result = job.run()
            rec.failed_scenarios = dict(job.failed)
            rec.status = "done"
            rec.message = (f"{len(job.failed)} scenario(s) not simulated: their worker died" if job.failed else "")
            rec_feasible = sum(o.verdict.feasible for o in result.outcomes)
            self.emit("behavior_done", behavior=rec.folder, status=rec.status, feasible=rec_feasible,
                      total=len(result.outcomes))
        except KeyboardInterrupt:
            rec.status, rec.message = "interrupted", "interrupted; run the same command again to resume"
            raise
        except (RegenError, OSError) as exc:
            rec.status = "failed"
            rec.message = redact(f"{exc}", credentials=False)
            self.emit("behavior_done", behavior=rec.folder, status="failed", message=rec.message)
        except Exception as exc:  # a bug in one behavior's job: recorded, the others go on
            log.exception("behavior %s failed", rec.folder)
            rec.status, rec.message = "failed", redact(f"{type(exc).__name__}: {exc}", credentials=False)
            self.emit("behavior_done", behavior=rec.folder, status="failed", message=rec.message)
        finally:
            self.save()  # credits this behavior's time up to now
            with self.lock:
                self._running.pop(i, None)

    def open_job(self, p: PlannedBehavior, rec: BehaviorRecord, gate: threading.Semaphore) -> _Job:
        backend = domains.make(p.behavior.domain)
        run = RunFolder(self.out / rec.folder)
        manifest = run.open(p.behavior, p.settings, backend.settings_key(p.behavior), fresh=self.fresh)
        try:
            job = MainJob(run, manifest, backend, p.settings, self.interrupts, replay=self.replay,
                          on_event=lambda ev: self.emit(ev.pop("event"), behavior=rec.folder, **ev),
                          tasks=self.tasks, model_gate=lambda: gate)
        except BaseException:
            run.unlock()
            raise
        return _Job(job, run)

    def end(self) -> None:
        """How the batch ended, into batch.json; then the summary and the report (a failure of
        those is logged: the runs are intact and a rerun writes them)."""
        rec = self.record
        statuses = {b.status for b in rec.behaviors}
        if rec.status == "running":
            rec.status = "failed" if statuses & {"failed"} else ("done" if statuses <= {"done"} else "interrupted")
            failed = [b.folder for b in rec.behaviors if b.status == "failed"]
            rec.message = (f"{len(failed)} behavior(s) failed ({', '.join(failed)}); fix what their message says "
                           "and run the same command again to resume") if failed else ""
        rec.finished = now()
        self.save()  # credits the wall time since the last save
        try:
            write_batch_report(self.out, summarize_batch(self.out))
        except Exception:
            log.warning("the batch summary or report of %s could not be written", self.out, exc_info=True)
        self.emit("batch_done", status=rec.status, wall_seconds=round(rec.wall_seconds, 1))


class _Job:
    """A main job with its run folder, unlocked when it ends however it ends."""

    def __init__(self, job: MainJob, run: RunFolder):
        self.job, self.run_folder = job, run

    @property
    def failed(self) -> dict[str, str]:
        return self.job.failed

    def run(self):
        try:
            return self.job.run()
        finally:
            self.run_folder.unlock()


def make_tasks(ray: str | None, workers: int | None) -> ScenarioTasks:
    """The batch's task pool: Ray at ``ray`` (an address or 'auto'), else ``workers`` processes
    of this machine (default: its cores)."""
    if workers is not None and workers < 1:
        raise ConfigError(f"--workers must be at least 1, not {workers}")
    if ray is not None:
        if not ray.strip():
            raise ConfigError("--ray is empty: give 'auto' or the cluster's address (HOST:PORT)")
        return RayTasks(ray, workers or (os.cpu_count() or 1))
    return ProcessTasks(workers or (os.cpu_count() or 1))


def run_batch(spec_file: str | Path, out: str | Path, *, ray: str | None = None, workers: int | None = None,
              replay: bool = False, fresh: bool = False, fill_coverage: bool = False,
              on_event: Callable[[dict[str, Any]], None] | None = None) -> BatchRecord:
    """Run (or resume) the batch of ``spec_file`` into ``out``: every entry checked before
    anything runs (:func:`~regen.batch.spec.plan`), then :class:`BatchJob`.

    Args:
        spec_file: the YAML spec (docs/batch.md).
        out: the batch folder; one run folder per behavior in it.
        ray: run scenarios as Ray tasks on this cluster ('auto' or HOST:PORT); None: processes.
        workers: processes (or, with Ray, the CPUs of a local cluster 'auto' starts).
        replay: forbid model calls; every answer must be in the run folders' caches.
        fresh: start over (each run folder's model cache is kept).
        fill_coverage: after the spec's behaviors, run one scenario per cause that presents a
            typology class a behavior does not cover yet (:mod:`regen.batch.fill`).
        on_event: progress events, each with the behavior's folder where it has one.
    """
    spec_path = Path(spec_file)
    spec, sha = read_spec(spec_path)
    planned = plan(spec, behavior_to_generate, export_options, base=spec_path.resolve().parent)
    names = folder_names(planned)
    out_dir = Path(out)
    record = open_batch(out_dir, spec_path, sha, names, planned, fresh=fresh)
    for p in planned:
        for line in p.lines:
            log.info("%s", line)
    tasks = make_tasks(ray, workers)
    record.executor = "ray" if ray is not None else "pool"
    record.workers, record.ray_address = tasks.workers, ray
    try:
        with Interrupts() as interrupts:
            return BatchJob(out_dir, record, planned, tasks, interrupts, replay=replay, fresh=fresh,
                            on_event=on_event, fill_coverage=fill_coverage).run()
    finally:
        with contextlib.suppress(Exception):
            tasks.close(cancel=True)


__all__ = ["BATCH_FILE", "BatchJob", "BatchRecord", "BehaviorRecord", "folder_names", "make_tasks", "run_batch"]
