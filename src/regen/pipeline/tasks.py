"""Where the scenarios of a run are simulated: worker processes on this machine
(:class:`ProcessTasks`, ``--workers N``) or Ray tasks on a cluster (:class:`RayTasks`, ``regen
batch --ray``). Both take the same task, :func:`regen.pipeline.stages.simulate_stage` (simulate,
verify, check the cause, draw, export: plain arguments in, plain data out, the scenario folder
written by the worker), and hand back :class:`concurrent.futures.Future` objects.

A worker that dies (killed, out of memory, a simulator's crash) loses only the scenario it was
running: that one is run once more on a fresh worker, then its future fails with
:class:`WorkerDied` saying so; the other scenarios are not touched. One that dies between two
scenarios loses nothing: a fresh worker takes its place.

Imports: the standard library; Ray only inside :class:`RayTasks`.
"""

from __future__ import annotations

import collections
import logging
import multiprocessing as mp
import os
import threading
import time
from collections.abc import Callable
from concurrent.futures import Future
from dataclasses import dataclass, field
from multiprocessing.connection import Connection, wait
from typing import Any, Protocol

from regen.errors import ConfigError, RegenError, install_hint
from regen.pipeline.zygote import Zygote, ZygoteGone, reply, stop

log = logging.getLogger(__name__)

ATTEMPTS = 2  # runs of a scenario whose worker died: the first and one retry


class WorkerDied(RegenError):
    """The process running a scenario died, on every attempt."""


class ScenarioTasks(Protocol):
    """Runs ``fn(*args)`` somewhere; a future of its result."""

    workers: int

    def submit(self, fn: Callable[..., Any], *args: Any) -> Future: ...

    def warm(self, fn: Callable[..., Any], *args: Any) -> list[Future]: ...

    def close(self, *, cancel: bool = False) -> None: ...


def _log_warm_failure(f: Future) -> None:
    exc = f.exception() if not f.cancelled() else None
    if exc is not None:  # the worker's first scenario does the work instead, and says what fails
        log.debug("warming a worker failed: %s: %s", type(exc).__name__, exc)


def _warm_each(tasks: ScenarioTasks, spare_core: bool, fn: Callable[..., Any], args: tuple[Any, ...],
               each: Callable[[], list[Future]] | None = None) -> list[Future]:
    """``fn(*args)`` once per worker of ``tasks`` (``each()`` where the executor can address its
    workers, else submitted once per worker) where they leave this machine a core
    (``spare_core``), its failure only logged: the shared part of both executors' ``warm``.
    Without a spare core the warming takes the caller's (its expansion, its model) and is paid
    again on no scenario's behalf (2 workers on 2 cores, measured: the batch took as long, or
    0.3 s longer on a local Ray)."""
    if not spare_core:
        return []
    futures = each() if each is not None else [tasks.submit(fn, *args) for _ in range(tasks.workers)]
    for f in futures:
        f.add_done_callback(_log_warm_failure)
    return futures


def _worker_main(conn: Connection, parent: int) -> None:
    """A worker process: run what the parent sends, one task at a time, until it sends None."""
    from regen.pipeline.workers import worker_init

    worker_init(parent)
    while True:
        try:
            job = conn.recv()
        except EOFError:
            return
        if job is None:
            return
        reply(conn, *job)


IMPORT_WAIT = 60.0  # [s] a worker is forked after at most this long waiting for other threads' imports


def imports_running() -> list[str]:
    """Modules another thread of this process is importing now (holding its import lock)."""
    from importlib import _bootstrap

    me = threading.get_ident()
    locks = getattr(_bootstrap, "_module_locks", None)
    if not isinstance(locks, dict):  # another Python's import machinery: nothing known
        return []
    running = []
    for name, ref in list(locks.items()):
        lock = ref() if callable(ref) else None
        if lock is not None and getattr(lock, "count", 0) and getattr(lock, "owner", me) != me:
            running.append(name)
    return running


def wait_for_imports(limit: float = IMPORT_WAIT) -> None:
    """Before a pool's first fork, where the caller already runs other threads (``regen
    generate --workers`` starts its pool after expansion): wait until no other thread is
    importing a module. A child forked while one was inherits that module's import lock, held
    by a thread it does not have, and waits for ever at its first import of it (seen: a killed
    worker's forked replacement hung in ``import_module`` and the batch with it; replacements
    come from the zygote or are spawned now); re-importing the half-run module in the child
    instead would run its registrations twice. Python holds its global import lock across the
    fork itself, so an import that starts now waits until the fork is done."""
    deadline = time.monotonic() + limit
    while (running := imports_running()) and time.monotonic() < deadline:
        time.sleep(0.005)
    if running:
        log.warning("forking a worker while %s are still being imported (waited %.0f s)",
                    ", ".join(running), limit)


@dataclass
class _Task:
    future: Future
    fn: Callable[..., Any]
    args: tuple[Any, ...]
    attempts: int = 0
    scenario: bool = True  # a scenario (retried, a death counted), not a worker's warm-up


@dataclass
class _Worker:
    process: Any
    conn: Connection
    task: _Task | None = None
    deaths: list[str] = field(default_factory=list)


class ProcessTasks:
    """``workers`` processes of this machine, each running one scenario at a time. A dispatcher
    thread hands tasks to idle workers, collects results, and replaces a worker that died,
    running its scenario once more (:data:`ATTEMPTS`).

    Where the platform forks, the workers are forked from the pool's zygote
    (:mod:`regen.pipeline.zygote`: forked once as the pool starts, single-threaded, the
    simulators loaded once by :meth:`warm`), as the first scenarios arrive and in place of any
    that die; without it (``zygote=False``, or after it died) the first workers are forked from
    this process at once and later ones spawned."""

    def __init__(self, workers: int, *, zygote: bool | None = None):
        if workers < 1:
            raise ConfigError(f"workers must be at least 1, not {workers}")
        self.workers = workers
        forks = "fork" in mp.get_all_start_methods()
        self._ctx = mp.get_context("fork" if forks else "spawn")
        self._later_ctx = mp.get_context("spawn")
        self._zygote: Zygote | None = None
        self._queue: collections.deque[_Task] = collections.deque()
        self._pool: list[_Worker] = []
        self._lock = threading.Condition()
        self._closing = False
        self._thread: threading.Thread | None = None
        # wakes the dispatcher while it waits on busy workers: a task submitted then starts at
        # once on an idle or new worker (it waited for the next result, or up to 0.5 s)
        self._wake_r, self._wake_w = mp.Pipe(duplex=False)
        self.deaths = 0  # workers that died while running a scenario (a figure for the summary)
        # forked now, before the caller's threads start drawing or calling models: a child forked
        # while another thread holds a lock (matplotlib's, logging's) inherits it held and hangs
        # on its first use (seen: a batch with pictures, a worker forked while the graph was drawn)
        if forks and zygote is not False:
            wait_for_imports()
            self._zygote = Zygote(self._ctx, _worker_main)
        else:
            self._pool = [self._start_worker() for _ in range(workers)]

    def submit(self, fn: Callable[..., Any], *args: Any) -> Future:
        fut: Future = Future()
        with self._lock:
            if self._closing:
                raise RuntimeError("the worker pool is closed")
            self._queue.append(_Task(fut, fn, args))
            self._dispatching()
        return fut

    def _dispatching(self) -> None:
        """The dispatcher thread started (once) and woken (under the lock)."""
        if self._thread is None:
            self._thread = threading.Thread(target=self._dispatch, name="regen-tasks", daemon=True)
            self._thread.start()
        self._lock.notify_all()
        self._wake_w.send_bytes(b"")

    def warm(self, fn: Callable[..., Any], *args: Any) -> list[Future]:
        """``fn(*args)`` ahead of the scenarios, the once-per-process work of a first scenario,
        done while the caller still expands: once, in the zygote, whose workers are forked with
        it (the first of them wait for it); without a zygote, on each idle worker, only where the
        workers leave this machine a core (:func:`_warm_each`)."""
        zygote = self._zygote
        if zygote is None:
            return _warm_each(self, self.workers < (os.cpu_count() or 1), fn, args,
                              each=lambda: self._send_to_each(fn, args))
        fut: Future = Future()
        fut.set_running_or_notify_cancel()

        def run() -> None:
            try:
                fut.set_result(zygote.warm(fn, args))
            except BaseException as exc:  # ZygoteGone too: the workers do that work themselves
                fut.set_exception(exc)

        threading.Thread(target=run, name="regen-warm", daemon=True).start()
        fut.add_done_callback(_log_warm_failure)
        return [fut]

    def _send_to_each(self, fn: Callable[..., Any], args: tuple[Any, ...]) -> list[Future]:
        """``fn(*args)`` sent straight to each idle worker, not queued: from the queue, a worker
        done with its first one could take the second too (seen under load: one worker warmed
        twice, the other not at all). Not run again if its worker dies (nothing is lost)."""
        futures = []
        with self._lock:
            if self._closing:
                return []
            for w in self._pool:
                if w.task is not None or not w.process.is_alive():
                    continue
                task = _Task(Future(), fn, args, attempts=ATTEMPTS, scenario=False)
                task.future.set_running_or_notify_cancel()
                try:
                    w.conn.send((fn, args))
                except (BrokenPipeError, ConnectionResetError):  # it died just now: the next assignment sees it
                    continue
                w.task = task
                futures.append(task.future)
            self._dispatching()
        return futures

    def _start_worker(self, *, later: bool = False) -> _Worker:
        """A worker process: forked by the zygote while there is one. Without it, ``later`` (in
        place of one that died, while this process's other threads run: drawing, calling models,
        importing) is a fresh interpreter, not a fork of this process: a child forked then
        inherits every lock another thread holds at that instant (an import's, matplotlib's, a
        model client's) held for ever, and hangs at its first use (seen: a killed worker's
        replacement hung in an import, and the batch with it)."""
        if self._zygote is not None:
            try:
                handle, conn = self._zygote.fork()
                return _Worker(handle, conn)
            except ZygoteGone as exc:
                log.warning("%s; spawning the workers from now on", exc)
                self._zygote = None
            later = True
        ctx = self._later_ctx if later else self._ctx
        parent, child = ctx.Pipe()
        p = ctx.Process(target=_worker_main, args=(child, os.getpid()), daemon=True, name="regen-worker")
        if ctx.get_start_method() == "fork":
            wait_for_imports()
        p.start()
        child.close()
        return _Worker(p, parent)

    def _assign(self) -> None:
        """Idle workers take queued tasks; new workers start while tasks wait (under the lock).
        An idle worker that died (killed between two scenarios) leaves the pool and a new one
        takes its place: no scenario was lost, so none counts an attempt."""
        while self._queue:
            idle = next((w for w in self._pool if w.task is None), None)
            if idle is not None and not idle.process.is_alive():
                self._left_idle(idle)
                continue
            if idle is None and len(self._pool) < self.workers:
                idle = self._start_worker(later=True)
                self._pool.append(idle)
            if idle is None:
                return
            task = self._queue.popleft()
            if not task.future.running() and not task.future.set_running_or_notify_cancel():
                continue  # cancelled while it waited
            try:
                idle.conn.send((task.fn, task.args))
            except (BrokenPipeError, ConnectionResetError):  # it died just now, before taking it
                self._queue.appendleft(task)
                self._left_idle(idle)
                continue
            task.attempts += 1
            idle.task = task

    def _left_idle(self, w: _Worker) -> None:
        """An idle worker that is gone: reaped and out of the pool (the next assignment starts
        another)."""
        w.process.join(timeout=1)
        log.warning("a worker process died between scenarios (exit code %s); starting another",
                    w.process.exitcode)
        w.conn.close()
        self._pool.remove(w)

    def _fail_all(self, exc: BaseException) -> None:
        """The dispatcher itself failed (a bug): every scenario not finished fails with it
        rather than waiting forever."""
        err = RuntimeError(f"the worker pool stopped: {type(exc).__name__}: {exc}")
        for w in self._pool:
            if w.task is not None and not w.task.future.done():
                w.task.future.set_exception(err)
            w.task = None
        while self._queue:
            task = self._queue.popleft()
            if task.future.running() or task.future.set_running_or_notify_cancel():
                task.future.set_exception(err)

    def _dispatch(self) -> None:
        try:
            self._dispatch_loop()
        except BaseException as exc:  # never a silent end: the callers wait on these futures
            log.exception("the worker pool's dispatcher failed")
            with self._lock:
                self._closing = True
                self._fail_all(exc)

    def _dispatch_loop(self) -> None:
        while True:
            while self._wake_r.poll():  # every wake-up so far: this pass looks at the queue anyway
                self._wake_r.recv_bytes()
            with self._lock:
                self._assign()
                busy = [w for w in self._pool if w.task is not None]
                if not busy:
                    if self._closing and not self._queue:
                        return
                    self._lock.wait(0.5)
                    continue
            # a forked worker's death shows on its pipe (it has no sentinel here)
            sentinels = [w.process.sentinel for w in busy if w.process.sentinel is not None]
            ready = wait([w.conn for w in busy] + sentinels + [self._wake_r], timeout=0.5)
            with self._lock:
                for w in busy:
                    if w.conn in ready and w.conn.poll():
                        self._finish(w)
                    elif w.process.sentinel is not None and w.process.sentinel in ready:
                        self._died(w)

    def _finish(self, w: _Worker) -> None:
        try:
            kind, value = w.conn.recv()
        except (EOFError, OSError):
            self._died(w)
            return
        task, w.task = w.task, None
        assert task is not None
        if kind == "ok":
            task.future.set_result(value)
        else:
            task.future.set_exception(value)

    def _died(self, w: _Worker) -> None:
        """A worker died: it leaves the pool; its scenario runs again, or fails after the last attempt."""
        w.process.join(timeout=1)
        code = w.process.exitcode
        w.conn.close()
        self._pool.remove(w)
        task, w.task = w.task, None
        if task is None:
            return
        if not task.scenario:
            task.future.set_exception(WorkerDied(f"the worker died while warming (exit code {code})"))
            return
        self.deaths += 1
        why = f"the worker process running it died (exit code {code})"
        if task.attempts < ATTEMPTS:
            log.warning("%s; running that scenario once more on a new worker", why)
            self._queue.appendleft(task)
        else:
            task.future.set_exception(WorkerDied(f"{why}, on each of {task.attempts} attempts"))

    def close(self, *, cancel: bool = False) -> None:
        """Stop taking tasks; with ``cancel``, queued ones are cancelled (running ones finish and
        are kept); then the workers leave."""
        with self._lock:
            self._closing = True
            if cancel:
                while self._queue:
                    self._queue.popleft().future.cancel()
            self._lock.notify_all()
            if not self._wake_w.closed:  # closed by an earlier close()
                self._wake_w.send_bytes(b"")
        if self._thread is not None:
            self._thread.join()
        for w in self._pool:
            stop(w.conn, w.process)
        self._pool.clear()
        if self._zygote is not None:
            self._zygote.close()
            self._zygote = None
        self._wake_r.close()
        self._wake_w.close()


def _ray() -> Any:
    try:
        import ray
    except ImportError:
        raise ConfigError("--ray needs Ray: " + install_hint("scale")) from None
    return ray


class RayTasks:
    """Ray tasks on the cluster at ``address`` (``ray.init(address=...)``: a user's cluster
    works unchanged). ``auto``: the cluster this machine is part of, or else a local one with
    ``workers`` CPUs. A task whose worker dies is retried once by Ray (``max_retries=1``), then
    fails with :class:`WorkerDied`."""

    def __init__(self, address: str, workers: int = 1):
        ray = _ray()
        self.address = address
        os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")  # no usage reports from an offline tool
        try:
            if address == "auto":
                try:
                    ray.init(address="auto", log_to_driver=False, logging_level="WARNING")
                except ConnectionError:
                    ray.init(num_cpus=workers, include_dashboard=False, log_to_driver=False,
                             logging_level="WARNING")
            else:
                ray.init(address=address, log_to_driver=False, logging_level="WARNING")
        except ConnectionError as exc:
            raise ConfigError(f"--ray {address}: no Ray cluster answers there ({exc}); start one with "
                              "'ray start --head' or give its address (HOST:PORT)") from None
        self.workers = int(ray.cluster_resources().get("CPU", workers))
        here = {"127.0.0.1", "localhost", ray.util.get_node_ip_address()}
        self._local_only = all(n.get("NodeManagerAddress") in here for n in ray.nodes() if n.get("Alive"))
        self._remote = ray.remote(max_retries=ATTEMPTS - 1, num_cpus=1)(_call)
        self._lock = threading.Lock()
        self.deaths = 0

    def submit(self, fn: Callable[..., Any], *args: Any) -> Future:
        ray = _ray()
        inner = self._remote.remote(fn, *args).future()
        outer: Future = Future()

        def done(f: Future) -> None:
            exc = f.exception()
            if exc is None:
                outer.set_result(f.result())
            elif isinstance(exc, (ray.exceptions.WorkerCrashedError, ray.exceptions.NodeDiedError,
                                  ray.exceptions.OwnerDiedError)):
                with self._lock:
                    self.deaths += 1
                outer.set_exception(WorkerDied(f"the Ray worker running it died, on each of {ATTEMPTS} "
                                               f"attempts ({type(exc).__name__})"))
            elif isinstance(exc, ray.exceptions.RayTaskError):
                outer.set_exception(exc.as_instanceof_cause())
            else:
                outer.set_exception(exc)

        inner.add_done_callback(done)
        return outer

    def warm(self, fn: Callable[..., Any], *args: Any) -> list[Future]:
        """``fn(*args)`` once per CPU of the cluster, ahead of the scenarios (Ray starts a worker
        process per task running at once): a fresh Ray worker's imports and first compilation
        happen while the driver still expands, not in its first scenario. Not where the cluster
        is this machine alone and takes all its cores (:func:`_warm_each`)."""
        return _warm_each(self, not self._local_only or self.workers < (os.cpu_count() or 1), fn, args)

    def close(self, *, cancel: bool = False) -> None:
        ray = _ray()
        if ray.is_initialized():
            ray.shutdown()


def _call(fn: Callable[..., Any], *args: Any) -> Any:
    """A Ray task: ``fn(*args)`` in a Ray worker."""
    return fn(*args)


__all__ = ["ATTEMPTS", "ProcessTasks", "RayTasks", "ScenarioTasks", "WorkerDied", "imports_running", "wait_for_imports"]
