"""The process a worker pool forks its workers from (:class:`regen.pipeline.tasks.ProcessTasks`).

A worker forked from the driver would inherit the driver's state at that instant: its threads'
locks held for ever (the driver runs model calls, drawing and imports in threads: a replacement
forked during an import once hung a whole batch), and none of the simulators loaded, so every
worker paid Scenic's imports and the world model's first compilation again in its first
scenario (1.7 s cold, measured; with 2 workers on 2 cores that time is taken from the other
worker and the driver). The zygote is forked once, when the pool starts, and stays
single-threaded: it loads the simulators once (:meth:`Zygote.warm`, on the core the driver does
not use while it expands its first behaviors), and forks each worker, the first ones and any that
take a dead one's place, with everything it loaded and no lock held. Each worker's pipe is a
socket pair the zygote makes and hands the driver (``SCM_RIGHTS``); a worker's death shows as
the end of its pipe, and the zygote, its parent, reaps it and tells its exit code.

Linux and other platforms that fork; elsewhere the pool spawns its workers.
"""

from __future__ import annotations

import os
import signal
import socket
import threading
import time
from collections.abc import Callable
from multiprocessing import reduction
from multiprocessing.connection import Connection
from typing import Any

REAP_EVERY = 0.2  # [s] the zygote reaps its dead workers at least this often
EXIT_CODE_WAIT = 2.0  # [s] the most the zygote waits for a worker whose pipe ended to exit


def _exit_code(status: int) -> int:
    """As :attr:`multiprocessing.Process.exitcode`: the exit status, or minus the signal."""
    return -os.WTERMSIG(status) if os.WIFSIGNALED(status) else os.WEXITSTATUS(status)


def _reap(codes: dict[int, int]) -> None:
    while True:
        try:
            pid, status = os.waitpid(-1, os.WNOHANG)
        except ChildProcessError:
            return
        if pid == 0:
            return
        codes[pid] = _exit_code(status)


def _fork_worker(conn: Connection, driver: int, worker_main: Callable[[Connection, int], None]) -> None:
    """Fork one worker; hand the driver its pid and its end of the worker's pipe."""
    ours, theirs = socket.socketpair()
    pid = os.fork()
    if pid == 0:  # the worker: it runs tasks until its pipe says stop, then leaves at once
        code = 0
        try:
            conn.close()
            ours.close()
            worker_main(Connection(theirs.detach()), os.getppid())
        except BaseException:
            code = 1
        finally:
            os._exit(code)
    theirs.close()
    try:
        conn.send(pid)
        reduction.send_handle(conn, ours.fileno(), driver)
    finally:
        ours.close()


def reply(conn: Connection, fn: Callable[..., Any], args: tuple[Any, ...]) -> None:
    """``fn(*args)`` run here and its outcome sent back: ``("ok", value)`` or ``("error", exc)``
    (a worker's task, the zygote's warm-up); the caller's future gets a task's own failure."""
    try:
        conn.send(("ok", fn(*args)))
    except Exception as exc:
        try:
            conn.send(("error", exc))
        except Exception:  # an exception that does not pickle: its text
            conn.send(("error", RuntimeError(f"{type(exc).__name__}: {exc}")))


def zygote_main(conn: Connection, driver: int, worker_main: Callable[[Connection, int], None]) -> None:
    """The zygote: forks workers, runs warm-ups, tells exit codes, one request at a time, until
    the driver sends None or goes."""
    from regen.pipeline.workers import worker_init

    worker_init(driver)  # dies with the driver (and its workers with it), ignores Ctrl-C
    codes: dict[int, int] = {}
    while True:
        if not conn.poll(REAP_EVERY):
            _reap(codes)
            continue
        try:
            msg = conn.recv()
        except EOFError:
            return
        if msg is None:
            return
        if msg[0] == "fork":
            if threading.active_count() > 1:  # a warm-up left a thread: a fork could inherit its locks
                conn.send(f"a warm-up left {threading.active_count() - 1} thread(s) running in the zygote")
                return
            _fork_worker(conn, driver, worker_main)
        elif msg[0] == "warm":
            reply(conn, msg[1], msg[2])
        elif msg[0] == "exit code":
            deadline = time.monotonic() + EXIT_CODE_WAIT
            while msg[1] not in codes and time.monotonic() < deadline:
                _reap(codes)
                time.sleep(0.005)
            conn.send(codes.pop(msg[1], None))


def stop(conn: Connection, process: Any, timeout: float = 5.0) -> None:
    """Ask a process that reads ``conn`` (a worker, the zygote) to leave; kill it if it has not
    within ``timeout`` seconds."""
    try:
        conn.send(None)
    except OSError:
        pass
    process.join(timeout=timeout)
    if process.is_alive():
        process.kill()
        process.join(timeout=timeout)


class ZygoteGone(Exception):
    """The zygote died (killed): the pool spawns its workers from now on."""


class Zygote:
    """The driver's side: one request at a time over the zygote's pipe."""

    def __init__(self, ctx: Any, worker_main: Callable[[Connection, int], None]):
        self._conn, child = ctx.Pipe()
        self.process = ctx.Process(target=zygote_main, args=(child, os.getpid(), worker_main), daemon=True,
                                   name="regen-zygote")
        self.process.start()
        child.close()
        self._lock = threading.Lock()

    def _ask(self, msg: tuple[Any, ...], answer: Callable[[], Any]) -> Any:
        with self._lock:
            try:
                self._conn.send(msg)
                return answer()
            except (OSError, EOFError) as exc:
                raise ZygoteGone(f"the pool's zygote is gone ({type(exc).__name__})") from None

    def fork(self) -> tuple[Forked, Connection]:
        """A new worker: its handle and the driver's end of its pipe."""
        def answer() -> tuple[int, int]:
            pid = self._conn.recv()
            if isinstance(pid, str):  # it will not fork (and has left)
                raise ZygoteGone(f"the pool's zygote stopped: {pid}")
            return pid, reduction.recv_handle(self._conn)

        pid, fd = self._ask(("fork",), answer)
        return Forked(pid, self), Connection(fd)

    def warm(self, fn: Callable[..., Any], args: tuple[Any, ...]) -> Any:
        """``fn(*args)`` in the zygote (every worker forked afterwards has what it loaded)."""
        kind, value = self._ask(("warm", fn, args), self._conn.recv)
        if kind == "error":
            raise value
        return value

    def exit_code(self, pid: int) -> int | None:
        try:
            return self._ask(("exit code", pid), self._conn.recv)
        except ZygoteGone:
            return None

    def close(self) -> None:
        with self._lock:
            stop(self._conn, self.process)
        self._conn.close()


class Forked:
    """A worker forked by the zygote, as the pool uses a :class:`multiprocessing.Process`
    (pid, is_alive, join, exitcode, kill); not the driver's child, so watched through /proc."""

    sentinel = None  # its death shows on its pipe

    def __init__(self, pid: int, zygote: Zygote):
        self.pid, self._zygote = pid, zygote
        self._code: int | None = None
        self._told = False

    def is_alive(self) -> bool:
        try:
            with open(f"/proc/{self.pid}/stat") as f:
                return f.read().rsplit(")", 1)[1].split()[0] not in ("Z", "X")
        except FileNotFoundError:
            return False
        except (OSError, IndexError):  # no /proc: a zombie counts alive until the zygote reaps it
            try:
                os.kill(self.pid, 0)
            except ProcessLookupError:
                return False
            return True

    def join(self, timeout: float | None = None) -> None:
        deadline = None if timeout is None else time.monotonic() + timeout
        while self.is_alive() and (deadline is None or time.monotonic() < deadline):
            time.sleep(0.005)

    @property
    def exitcode(self) -> int | None:
        if not self._told and not self.is_alive():
            self._code, self._told = self._zygote.exit_code(self.pid), True
        return self._code

    def kill(self) -> None:
        try:
            os.kill(self.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass


__all__ = ["Forked", "Zygote", "ZygoteGone", "reply", "stop", "zygote_main"]
