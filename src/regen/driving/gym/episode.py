"""One policy-loop episode driven step by step from outside (inversion of control).

Scenic's simulation loop owns control: :func:`regen.driving.testing.loop.run_policy` calls the
policy every step. Here it runs in a worker thread whose policy hands each observation to the
caller through a queue and blocks until the caller's action comes back, so ``start()`` and
``step(action)`` return the next observation as a Gymnasium env needs.

Scenic keeps the running simulation in module globals, so one process runs one simulation at a
time: an episode holds :data:`_SCENIC` from its start until its worker has finished, and a
second episode started meanwhile (another env in the same process) raises at once instead of
corrupting the first. Scenic's stuck-behavior warning installs a SIGALRM handler, which only
the main thread may do; the worker switches that warning off while it runs.
"""

from __future__ import annotations

import queue
import threading
from collections.abc import Callable

from regen.driving.testing.policies import Action, Observation
from regen.errors import RegenError

ANSWER_TIMEOUT = 120.0  # [s] wall time the simulation may take to answer one step before we give up

_SCENIC = threading.Lock()  # held while an episode's simulation exists in this process
_ABORT = object()  # sent instead of an action to end the simulation early


class EpisodeAborted(Exception):
    """Raised inside the policy to end the simulation (run_policy reports it as a policy fault,
    with the trace up to that step)."""


class Episode:
    """A run_policy in a worker thread: ``start()`` then ``step(action)`` until either returns None
    (the simulation ended by itself: :attr:`run` or :attr:`error` is set); ``stop()`` ends it
    early and returns the Episode. Always call ``stop()`` (it is idempotent)."""

    def __init__(self, prepare: Callable[[], object], *, answer_timeout: float = ANSWER_TIMEOUT):
        self._prepare = prepare  # () -> regen.driving.testing.loop.Prepared, run under the lock
        self._answer_timeout = answer_timeout
        self._to_env: queue.Queue = queue.Queue()
        self._to_sim: queue.Queue = queue.Queue()
        self._thread: threading.Thread | None = None
        self._holds_lock = False
        self._waiting = False  # the worker waits for an action
        self.prepared = None
        self.run = None  # regen.harness.contract.Episode once the worker returned
        self.error: BaseException | None = None  # what the worker raised instead

    @property
    def alive(self) -> bool:
        return self._waiting

    def start(self) -> Observation | None:
        if not _SCENIC.acquire(blocking=False):
            raise RegenError("another regen/Driving-v0 episode is running in this process: Scenic "
                             "runs one simulation per process. Close or finish it first, or run "
                             "several envs in subprocesses (gymnasium.vector.AsyncVectorEnv, "
                             "stable-baselines3 SubprocVecEnv)")
        self._holds_lock = True
        try:
            self.prepared = self._prepare()
            self._thread = threading.Thread(target=self._work, daemon=True, name="regen-gym-episode")
            self._thread.start()
            return self._next()
        except BaseException:
            self.stop()
            raise

    def step(self, action: Action) -> Observation | None:
        if not self._waiting:
            raise RegenError("the episode's simulation has ended; reset the env")
        self._waiting = False
        self._to_sim.put(action)
        return self._next()

    def stop(self):
        """End the simulation (if it still runs), wait for the worker, release the process lock;
        the Episode (None if the simulation failed or never started)."""
        try:
            if self._waiting:
                self._waiting = False
                self._to_sim.put(_ABORT)
                while self._next() is not None:  # the worker may still hand over an observation
                    self._waiting = False
                    self._to_sim.put(_ABORT)
            if self._thread is not None:
                self._thread.join(self._answer_timeout)
        finally:
            self._release()
        return self.run

    def _release(self) -> None:
        if self._holds_lock and (self._thread is None or not self._thread.is_alive()):
            self._holds_lock = False
            _SCENIC.release()

    def _next(self) -> Observation | None:
        try:
            kind, value = self._to_env.get(timeout=self._answer_timeout)
        except queue.Empty:
            raise RegenError(f"the simulation did not answer within {self._answer_timeout:g} s") from None
        if kind == "obs":
            self._waiting = True
            return value
        if kind == "end":
            self.run = value
        else:
            self.error = value
        self._thread.join()  # it has nothing left to do but to exit
        self._release()
        return None

    def _policy(self, obs: Observation) -> Action:
        self._to_env.put(("obs", obs))
        action = self._to_sim.get()
        if action is _ABORT:
            raise EpisodeAborted("the env ended the episode")
        return action

    def _work(self) -> None:
        from scenic.core import dynamics

        from regen.driving.testing.loop import run_policy

        previous = dynamics.stuckBehaviorWarningTimeout
        dynamics.stuckBehaviorWarningTimeout = 0  # its SIGALRM handler needs the main thread
        try:
            prep = self.prepared
            # one step more than the scenario lasts, so the observation after the last action
            # reaches the env; the env ends the episode there
            run = run_policy(prep, self._policy, step_timeout=None, steps=prep.steps + 1)
            self._to_env.put(("end", run))
        except BaseException as exc:  # noqa: BLE001 - handed to the env thread
            self._to_env.put(("error", exc))
        finally:
            dynamics.stuckBehaviorWarningTimeout = previous


__all__ = ["ANSWER_TIMEOUT", "Episode", "EpisodeAborted"]
