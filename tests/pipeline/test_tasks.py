"""Scenario tasks on worker processes: results come back, a task's own error is its own, and a
worker that dies loses only the scenario it was running, which runs once more and then fails."""

from __future__ import annotations

import os
import threading
import time
from pathlib import Path

import pytest

from regen.pipeline.tasks import ATTEMPTS, ProcessTasks, WorkerDied


def square(x: int) -> int:
    return x * x


def boom(msg: str) -> None:
    raise ValueError(msg)


def die_once(marker: str) -> int:
    """Kills its worker the first time (as a simulator crash or kill -9 would), then answers."""
    m = Path(marker)
    if not m.exists():
        m.write_text("died")
        os._exit(137)
    return os.getpid()


def slow_pid(seconds: float) -> int:
    import time

    time.sleep(seconds)
    return os.getpid()


HELD = threading.Lock()  # held by a thread of the test process while a replacement worker starts


def take_held_lock() -> bool:
    """In a worker: whether HELD can be taken (a forked child inherits it held for ever)."""
    got = HELD.acquire(timeout=3)
    if got:
        HELD.release()
    return got


def always_die(counter: str) -> None:
    with open(counter, "a") as f:
        f.write("x")
    os._exit(137)


@pytest.fixture(params=[True, False], ids=["zygote", "no-zygote"])
def tasks(request):
    t = ProcessTasks(2, zygote=request.param)
    yield t
    t.close(cancel=True)


def test_results_come_back_in_any_order_of_completion(tasks) -> None:
    futs = [tasks.submit(square, i) for i in range(6)]
    assert [f.result(timeout=60) for f in futs] == [0, 1, 4, 9, 16, 25]


def test_a_tasks_own_error_reaches_its_future_and_the_worker_lives_on(tasks) -> None:
    bad = tasks.submit(boom, "bad input")
    with pytest.raises(ValueError, match="bad input"):
        bad.result(timeout=60)
    assert tasks.submit(square, 3).result(timeout=60) == 9
    assert tasks.deaths == 0


def test_a_worker_that_dies_loses_only_its_scenario_which_runs_again(tasks, tmp_path) -> None:
    others = [tasks.submit(square, i) for i in range(4)]
    once = tasks.submit(die_once, str(tmp_path / "marker"))
    pid = once.result(timeout=60)
    assert pid != os.getpid() and (tmp_path / "marker").read_text() == "died"
    assert [f.result(timeout=60) for f in others] == [0, 1, 4, 9]
    assert tasks.deaths == 1


def test_a_scenario_whose_worker_always_dies_fails_after_the_retry(tasks, tmp_path) -> None:
    counter = tmp_path / "attempts"
    doomed = tasks.submit(always_die, str(counter))
    fine = tasks.submit(square, 7)
    with pytest.raises(WorkerDied, match=f"died .*{ATTEMPTS} attempts"):
        doomed.result(timeout=60)
    assert counter.read_text() == "x" * ATTEMPTS
    assert fine.result(timeout=60) == 49
    assert tasks.submit(square, 2).result(timeout=60) == 4  # the pool goes on with fresh workers


def test_close_with_cancel_cancels_what_has_not_started(tmp_path) -> None:
    t = ProcessTasks(1)
    futs = [t.submit(square, i) for i in range(50)]
    t.close(cancel=True)
    assert any(f.cancelled() for f in futs)
    assert all(f.result() == i * i for i, f in enumerate(futs) if f.done() and not f.cancelled())
    with pytest.raises(RuntimeError, match="closed"):
        t.submit(square, 1)


@pytest.mark.parametrize("zygote", [True, False])
def test_a_worker_killed_between_scenarios_is_replaced_and_nothing_is_lost(zygote) -> None:
    """kill -9 of an idle worker (seen in a batch: the pool then sent it the next scenario, the
    dispatcher died of the broken pipe and the batch waited forever): a new worker takes its
    place, every scenario runs once, and no death is counted (no scenario was running)."""
    import signal

    t = ProcessTasks(2, zygote=zygote)
    try:
        assert [f.result(timeout=60) for f in [t.submit(slow_pid, 0.3) for _ in range(4)]]  # both workers up
        assert [f.result(timeout=60) for f in [t.submit(square, i) for i in range(4)]] == [0, 1, 4, 9]
        victim = t._pool[0].process  # idle now: every task above has finished
        os.kill(victim.pid, signal.SIGKILL)
        victim.join(timeout=10)
        futs = [t.submit(os.getpid) for _ in range(6)]
        pids = {f.result(timeout=60) for f in futs}
        assert victim.pid not in pids and os.getpid() not in pids
        assert len(t._pool) == 2 and all(w.process.is_alive() for w in t._pool)
        assert t.deaths == 0
    finally:
        t.close(cancel=True)


def test_a_worker_whose_pipe_breaks_as_it_gets_a_scenario_is_replaced(monkeypatch) -> None:
    """The worker dies between the liveness check and the send: the scenario goes to another
    worker, not counted as an attempt."""
    t = ProcessTasks(1)
    try:
        assert t.submit(square, 2).result(timeout=60) == 4
        first = t._pool[0]

        def broken(_obj) -> None:
            raise BrokenPipeError(32, "Broken pipe")

        monkeypatch.setattr(first.conn, "send", broken)
        fut = t.submit(square, 5)
        assert fut.result(timeout=60) == 25
        assert first not in t._pool and len(t._pool) == 1 and t.deaths == 0
    finally:
        t.close(cancel=True)


def test_a_dispatcher_failure_fails_the_scenarios_instead_of_hanging(monkeypatch) -> None:
    """A bug in the dispatcher ends every unfinished scenario with an error (before, the thread
    died and the futures never completed)."""
    t = ProcessTasks(1)
    try:
        def bug() -> None:
            raise KeyError("dispatcher bug")

        monkeypatch.setattr(t, "_assign", bug)
        fut = t.submit(square, 3)
        with pytest.raises(RuntimeError, match="the worker pool stopped: KeyError"):
            fut.result(timeout=60)
        with pytest.raises(RuntimeError, match="closed"):
            t.submit(square, 1)
    finally:
        t.close(cancel=True)


@pytest.fixture
def forked():
    """A pool without a zygote: its workers forked from this process at once (and warmed each)."""
    t = ProcessTasks(2, zygote=False)
    yield t
    t.close(cancel=True)


def test_warming_runs_once_on_each_worker_and_a_failure_stays_quiet(forked, monkeypatch) -> None:
    tasks = forked
    monkeypatch.setattr(os, "cpu_count", lambda: 8)  # the two workers leave the caller cores
    workers = {w.process.pid for w in tasks._pool}
    pids = [f.result(timeout=30) for f in tasks.warm(slow_pid, 0.5)]
    assert sorted(pids) == sorted(workers)  # one each, not both on the first idle worker
    failed = tasks.warm(boom, "no simulator here")
    assert all(isinstance(f.exception(timeout=30), ValueError) for f in failed)
    assert tasks.submit(square, 7).result(timeout=30) == 49  # the workers go on


def test_an_instant_warm_up_still_reaches_each_worker(forked, monkeypatch) -> None:
    """A warm-up that ends at once (a worker already warm) must not let the first worker take
    the second worker's too (seen in a batch on a loaded machine: one worker warmed twice, the
    other cold): the pool is slow to hand out work here, and each worker still gets one."""
    tasks = forked
    import time

    monkeypatch.setattr(os, "cpu_count", lambda: 8)
    slow_submit = tasks.submit

    def submit(fn, *args):
        fut = slow_submit(fn, *args)
        time.sleep(0.3)  # the first worker is done before the next one is asked
        return fut

    monkeypatch.setattr(tasks, "submit", submit)
    workers = sorted(w.process.pid for w in tasks._pool)
    for _ in range(3):
        assert sorted(f.result(timeout=30) for f in tasks.warm(os.getpid)) == workers
    assert tasks.submit(square, 4).result(timeout=30) == 16 and tasks.deaths == 0


def test_a_worker_killed_while_warming_counts_no_death_and_is_replaced(forked, monkeypatch) -> None:
    tasks = forked
    import signal

    monkeypatch.setattr(os, "cpu_count", lambda: 8)
    futs = tasks.warm(slow_pid, 2.0)
    victim = tasks._pool[0].process
    os.kill(victim.pid, signal.SIGKILL)
    outcomes = [f.exception(timeout=30) for f in futs]
    assert sum(isinstance(e, WorkerDied) for e in outcomes) == 1 and outcomes.count(None) == 1
    assert tasks.deaths == 0  # no scenario was running
    pids = {f.result(timeout=60) for f in [tasks.submit(slow_pid, 0.2) for _ in range(4)]}
    assert victim.pid not in pids and len(tasks._pool) == 2


def test_workers_that_take_every_core_are_not_warmed(forked, monkeypatch) -> None:
    tasks = forked
    monkeypatch.setattr(os, "cpu_count", lambda: 2)  # the two workers and the caller share them
    assert tasks.warm(slow_pid, 0.5) == []
    assert tasks.submit(square, 3).result(timeout=30) == 9


def load_once() -> int:
    """A warm-up: what a simulator's first load leaves in its process (here, an environment mark)."""
    os.environ["REGEN_TEST_WARMED_IN"] = str(os.getpid())
    return os.getpid()


def warmed_in() -> tuple[int, str | None]:
    return os.getpid(), os.environ.get("REGEN_TEST_WARMED_IN")


def test_the_zygote_warms_once_and_every_worker_is_forked_with_it() -> None:
    """The simulators load once, in the zygote, while the caller goes on; the workers, forked
    afterwards from it (a replacement too), start with them loaded; the caller is untouched."""
    import signal

    t = ProcessTasks(2)
    try:
        (fut,) = t.warm(load_once)
        zygote = fut.result(timeout=30)
        assert zygote not in (os.getpid(), None) and "REGEN_TEST_WARMED_IN" not in os.environ
        first = [f.result(timeout=60) for f in [t.submit(slow_pid, 0.3) for _ in range(2)]]
        seen = [f.result(timeout=60) for f in [t.submit(warmed_in) for _ in range(4)]]
        assert {pid for pid, _ in seen} <= set(first) and {w for _, w in seen} == {str(zygote)}
        os.kill(first[0], signal.SIGKILL)
        t._pool[0].process.join(timeout=10)
        again = [f.result(timeout=60) for f in [t.submit(warmed_in) for _ in range(4)]]
        assert first[0] not in {pid for pid, _ in again} and {w for _, w in again} == {str(zygote)}
        failed = t.warm(boom, "no simulator here")
        assert isinstance(failed[0].exception(timeout=30), ValueError)  # only logged by the batch
        assert t.submit(square, 5).result(timeout=30) == 25
    finally:
        t.close(cancel=True)


def test_a_killed_zygote_leaves_a_pool_that_spawns_its_workers() -> None:
    """kill -9 of the zygote takes its workers with it (they die with their parent): their
    scenarios run again on spawned workers, and the pool goes on."""
    import signal

    t = ProcessTasks(2)
    try:
        assert t.submit(square, 3).result(timeout=60) == 9
        zygote = t._zygote.process
        running = [t.submit(slow_pid, 1.0) for _ in range(2)]
        time.sleep(0.3)
        os.kill(zygote.pid, signal.SIGKILL)
        pids = {f.result(timeout=120) for f in running + [t.submit(slow_pid, 0.1) for _ in range(3)]}
        assert os.getpid() not in pids and t._zygote is None
        assert [f.result(timeout=60) for f in [t.submit(square, i) for i in range(3)]] == [0, 1, 4]
    finally:
        t.close(cancel=True)


def import_slow_module(name: str) -> str:
    import importlib

    return importlib.import_module(name).WHERE


def test_a_worker_is_forked_after_another_threads_import_not_during_it(tmp_path, monkeypatch) -> None:
    """A replacement worker is forked while the batch's other threads run; forked while one of
    them imported a module, it got that module's lock held for ever (a batch hung this way after
    a worker was killed). The fork waits for the import, and the worker has the whole module."""
    import sys
    import threading
    import time

    from regen.pipeline.tasks import imports_running

    flag = tmp_path / "go"
    (tmp_path / "regen_slow_module.py").write_text(
        "import os, time\n"
        f"while not os.path.exists({str(flag)!r}):\n"
        "    time.sleep(0.02)\n"
        "WHERE = 'imported'\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    importing = threading.Thread(target=import_slow_module, args=("regen_slow_module",), daemon=True)
    importing.start()
    time.sleep(0.5)  # the thread is inside the module's body, holding its import lock
    assert imports_running() == ["regen_slow_module"]
    threading.Timer(1.0, flag.write_text, args=("",)).start()
    t0 = time.monotonic()
    tasks = ProcessTasks(1)  # forks once the import is done
    try:
        assert time.monotonic() - t0 >= 0.4 and not importing.is_alive()
        assert tasks.submit(import_slow_module, "regen_slow_module").result(timeout=30) == "imported"
    finally:
        flag.write_text("")
        importing.join(timeout=10)
        for w in tasks._pool:  # a worker hung in the import (the fault) must not hang the tests
            w.process.kill()
        tasks.close(cancel=True)
        sys.modules.pop("regen_slow_module", None)


def test_a_worker_started_in_place_of_a_dead_one_inherits_no_lock_another_thread_holds() -> None:
    """A replacement worker starts while the caller's other threads run (drawing, calling models);
    forked, it inherited every lock one of them held at that instant, held for ever (an import's
    hung a batch). It is a fresh process: the lock is free in it, and the scenario runs."""
    import signal

    t = ProcessTasks(1)
    release = threading.Event()
    holder = threading.Thread(target=lambda: (HELD.acquire(), release.wait(30), HELD.release()), daemon=True)
    try:
        assert t.submit(take_held_lock).result(timeout=60) is True  # the first worker, forked before
        victim = t._pool[0].process
        os.kill(victim.pid, signal.SIGKILL)
        victim.join(timeout=10)
        holder.start()
        while not HELD.locked():
            pass
        assert t.submit(take_held_lock).result(timeout=60) is True
        assert t._pool[0].process.pid != victim.pid
    finally:
        release.set()
        holder.join(timeout=10)
        t.close(cancel=True)


def start_a_thread() -> int:
    import threading

    threading.Thread(target=time.sleep, args=(30,), daemon=True).start()
    return threading.active_count()


def test_a_warm_up_that_leaves_a_thread_makes_the_pool_spawn_instead_of_forking(caplog) -> None:
    """A domain's warm-up that starts a thread (against its contract) would make every fork from
    the zygote unsafe: the zygote refuses to fork, and the pool spawns its workers."""
    t = ProcessTasks(1)
    try:
        (fut,) = t.warm(start_a_thread)
        assert fut.result(timeout=30) == 2
        with caplog.at_level("WARNING", logger="regen.pipeline.tasks"):
            assert t.submit(square, 6).result(timeout=120) == 36
        assert t._zygote is None and "left 1 thread(s) running" in caplog.text
    finally:
        t.close(cancel=True)
