"""A policy call under a per-step wall-time limit, shared by every domain's policy loop.

:func:`call_with_timeout` turns whatever goes wrong inside a user's policy into a
:class:`PolicyFailure` with a kind (``exception`` or ``timeout``) and a reason in words, so a
policy loop can end the episode as a failure of the policy instead of crashing the suite.
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Callable


class PolicyFailure(Exception):
    """A fault of the policy under test: ``kind`` is 'exception', 'invalid_action', 'timeout' or
    'crash' (its process ended or broke the pipe's protocol)."""

    def __init__(self, kind: str, reason: str):
        super().__init__(reason)
        self.kind, self.reason = kind, reason


class _Timeout(BaseException):
    """Raised inside a policy by the step alarm (BaseException: a policy's ``except Exception``
    must not swallow it)."""


def _alarm(signum, frame):
    raise _Timeout


def call_with_timeout(fn: Callable, arg: object, timeout: float | None) -> object:
    """fn(arg), stopped after ``timeout`` [s]: PolicyFailure('timeout'); any exception of fn:
    PolicyFailure('exception').

    On POSIX an interval timer (SIGALRM) interrupts the policy (costs microseconds; Scenic
    itself needs the main thread and uses SIGALRM only while its own behaviors run, not here);
    elsewhere the policy runs in a daemon thread that is abandoned on timeout. A policy in its
    own process (:class:`regen.harness.process.PolicyProcess`, what ``regen test`` runs) is
    timed by the harness's wall clock instead and killed at the timeout.
    """
    remote = getattr(fn, "call_within", None)
    if remote is not None:
        return remote(arg, timeout)
    if timeout is None:
        try:
            return fn(arg)
        except Exception as exc:
            raise PolicyFailure("exception", f"the policy raised {type(exc).__name__}: {exc}") from None
    too_slow = PolicyFailure("timeout", f"the policy took longer than the step timeout of {timeout:g} s")
    if hasattr(signal, "setitimer") and threading.current_thread() is threading.main_thread():
        previous = signal.signal(signal.SIGALRM, _alarm)
        try:
            signal.setitimer(signal.ITIMER_REAL, timeout)
            try:
                return fn(arg)
            finally:
                signal.setitimer(signal.ITIMER_REAL, 0)
        except _Timeout:
            raise too_slow from None
        except Exception as exc:
            raise PolicyFailure("exception", f"the policy raised {type(exc).__name__}: {exc}") from None
        finally:
            signal.signal(signal.SIGALRM, previous)
    box: dict[str, object] = {}

    def work() -> None:
        try:
            box["value"] = fn(arg)
        except BaseException as exc:  # noqa: BLE001 - reported as the policy's failure
            box["error"] = exc

    th = threading.Thread(target=work, daemon=True, name="regen-policy")
    th.start()
    th.join(timeout)
    if th.is_alive():
        raise too_slow
    if "error" in box:
        exc = box["error"]
        raise PolicyFailure("exception", f"the policy raised {type(exc).__name__}: {exc}")
    return box.get("value")


def reset_policy(policy: object, timeout: float | None) -> None:
    """The policy's ``reset()`` before an episode, when it has one, under the step timeout."""
    remote = getattr(policy, "reset_within", None)
    if remote is not None:
        remote(timeout)
        return
    reset = getattr(policy, "reset", None)
    if callable(reset):
        call_with_timeout(lambda _: reset(), None, timeout)


__all__ = ["PolicyFailure", "call_with_timeout", "reset_policy"]
