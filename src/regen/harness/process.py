"""The user's policy in its own process, spoken to over a pipe.

``regen test`` runs code it did not write. The harness keeps the simulator, the oracle and the
result files; the policy runs in a child process (:mod:`regen.harness.worker`) that only sees
observations and returns actions. Whatever the policy does there (``os._exit``, ``sys.exit``,
a hang that catches every exception, threads that never end, ``os.chdir``, replacing functions
of the harness's modules) ends or corrupts only that process: the harness measures each step by
its own wall clock, kills the child's whole process group when the step timeout passes or the
child dies, and starts a fresh one for the next case.

Per step the observation is pickled to the child and the action comes back as JSON: about
0.1 ms on this machine's CPU for a driving observation with ten actors (``benchmarks/bench_policy.py``
prints the figure), next to ~1 ms of simulation per step. Starting the child costs one Python
interpreter plus the domain's policy module (about 0.3-0.6 s), paid once per ``regen test`` and
again only after a case in which the policy faulted.

The child's standard output and error go to a log file (``policy.log`` beside ``tests.json``), so
a policy's prints are kept without garbling the terminal. The language-model API keys the
toolkit reads are not passed to the child: a key goes only to the service it belongs to.
"""

from __future__ import annotations

import contextlib
import json
import os
import pickle
import select
import signal
import struct
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

from regen.errors import ConfigError
from regen.harness.contract import PolicyHarness
from regen.harness.timeout import PolicyFailure

_HEADER = struct.Struct(">I")
MAX_ANSWER = 1 << 20  # bytes: an answer larger than this is not an action
START_TIMEOUT = 300.0  # [s] for the child to import the policy (a policy may load a network)
#: Variables of the toolkit's language-model providers, never handed to a policy.
PROVIDER_KEYS = ("OPENAI_API_KEY", "ANTHROPIC_API_KEY", "REGEN_OPENAI_API_KEY", "REGEN_ANTHROPIC_API_KEY")


class _Gone(Exception):
    """The child closed its pipe or sent something that is not an answer."""


def harness_entry(harness: PolicyHarness) -> str:
    """``module:Class`` of a harness, which the child imports and instantiates."""
    cls = type(harness)
    return f"{cls.__module__}:{cls.__qualname__}"


class PolicyProcess:
    """A policy SPEC loaded and run in a child process; called like the policy itself.

    :meth:`start` loads it (ConfigError with the child's message when the SPEC does not load);
    :meth:`call_within` and :meth:`reset_within` are what the domains' policy loops call through
    :func:`regen.harness.timeout.call_with_timeout` and :func:`regen.harness.timeout.reset_policy`.
    After any fault of the policy the process is dead or suspect: :meth:`ensure_fresh` starts a
    new one before the next case.
    """

    def __init__(self, harness: PolicyHarness, spec: str, *, log_path: str | Path | None = None,
                 start_timeout: float = START_TIMEOUT):
        self.harness, self.spec = harness, spec
        self.log_path = Path(log_path) if log_path is not None else None
        self.start_timeout = start_timeout
        self.proc: subprocess.Popen | None = None
        self._r: int | None = None  # we read answers here
        self._w: int | None = None  # we write requests here
        self.suspect = False  # the policy faulted: start afresh before the next case
        self.starts = 0

    # --- life cycle ------------------------------------------------------------------------

    def start(self) -> None:
        """Start the child and wait until the policy is loaded; ConfigError when it is not."""
        self.close()
        to_child_r, to_child_w = os.pipe()
        from_child_r, from_child_w = os.pipe()
        env = {k: v for k, v in os.environ.items() if k not in PROVIDER_KEYS}
        env["PYTHONUNBUFFERED"] = "1"  # a policy's print() reaches policy.log before the process is killed
        log = subprocess.DEVNULL
        if self.log_path is not None:
            self.log_path.parent.mkdir(parents=True, exist_ok=True)
            log = open(self.log_path, "ab")  # noqa: SIM115 - handed to the child, closed below
        try:
            self.proc = subprocess.Popen(
                [sys.executable, "-m", "regen.harness.worker", harness_entry(self.harness), self.spec,
                 str(to_child_r), str(from_child_w)],
                pass_fds=(to_child_r, from_child_w), stdin=subprocess.DEVNULL, stdout=log,
                stderr=subprocess.STDOUT, start_new_session=True, env=env, close_fds=True)
        finally:
            os.close(to_child_r)
            os.close(from_child_w)
            if log is not subprocess.DEVNULL:
                log.close()
        self._r, self._w = from_child_r, to_child_w
        self.starts += 1
        self.suspect = False
        try:
            answer = self._receive(time.monotonic() + self.start_timeout)
        except TimeoutError:
            self.close()
            raise ConfigError(f"policy {self.spec} did not load within {self.start_timeout:g} s") from None
        except _Gone:
            code = self._reap()
            self.close()
            raise ConfigError(f"the policy process ended (exit code {code}) while loading {self.spec}"
                              f"{self._see_log()}") from None
        if "config" in answer:
            self.close()
            raise ConfigError(str(answer["config"]))
        if answer.get("ready") is not True:
            self.close()
            raise ConfigError(f"the policy process for {self.spec} answered {str(answer)[:200]} instead of "
                              "starting")

    def ensure_fresh(self) -> None:
        """A live process that has not faulted, started anew if needed (before every case)."""
        if self.proc is None or self.suspect or self.proc.poll() is not None:
            self.start()

    def close(self) -> None:
        """Kill the child's whole process group (threads and children it started included)."""
        for fd in (self._r, self._w):
            if fd is not None:
                with contextlib.suppress(OSError):
                    os.close(fd)
        self._r = self._w = None
        proc, self.proc = self.proc, None
        if proc is None:
            return
        with contextlib.suppress(ProcessLookupError, PermissionError):
            os.killpg(proc.pid, signal.SIGKILL)
        with contextlib.suppress(ProcessLookupError):
            proc.kill()
        with contextlib.suppress(subprocess.TimeoutExpired):
            proc.wait(timeout=10)

    def __enter__(self) -> PolicyProcess:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __del__(self) -> None:
        with contextlib.suppress(Exception):
            self.close()

    # --- the policy's calls ---------------------------------------------------------------

    def __call__(self, observation: Any) -> Any:
        return self.call_within(observation, None)

    def call_within(self, observation: Any, timeout: float | None) -> Any:
        """The policy's action for one observation, in the domain's action type; PolicyFailure
        ('timeout', 'exception', 'invalid_action' or 'crash') for any fault of the policy."""
        answer = self._ask(("act", observation), timeout, "a step")
        if "action" in answer:
            try:
                return self.harness.action_from_wire(answer["action"])
            except (TypeError, ValueError, OverflowError) as exc:
                self.suspect = True
                raise PolicyFailure("invalid_action", f"the policy's action is not valid: {exc}") from None
        self.suspect = True
        if "invalid" in answer:
            raise PolicyFailure("invalid_action", str(answer["invalid"]))
        if "exception" in answer:
            raise PolicyFailure("exception", f"the policy raised {answer['exception']}")
        raise PolicyFailure("crash", f"the policy process answered {str(answer)[:200]} instead of an action")

    def reset_within(self, timeout: float | None) -> None:
        """The policy's ``reset()`` (when it has one) before an episode."""
        answer = self._ask(("reset", None), timeout, "reset()")
        if "exception" in answer:
            self.suspect = True
            raise PolicyFailure("exception", f"the policy's reset() raised {answer['exception']}")

    # --- the pipe --------------------------------------------------------------------------

    def _ask(self, request: tuple[str, Any], timeout: float | None, what: str) -> dict[str, Any]:
        if self.proc is None or self._w is None:
            self.ensure_fresh()
        deadline = None if timeout is None else time.monotonic() + timeout
        data = pickle.dumps(request, protocol=pickle.HIGHEST_PROTOCOL)
        try:
            self._write(_HEADER.pack(len(data)) + data, deadline)
            return self._receive(deadline)
        except TimeoutError:
            self.close()
            self.suspect = True
            raise PolicyFailure("timeout", f"the policy took longer than the step timeout of {timeout:g} s "
                                           f"({what}); its process was stopped") from None
        except _Gone:
            code = self._reap()
            self.close()
            self.suspect = True
            raise PolicyFailure("crash", f"the policy process ended (exit code {code}) during {what}"
                                         f"{self._see_log()}") from None

    def _write(self, payload: bytes, deadline: float | None) -> None:
        view = memoryview(payload)
        while view:
            if not select.select([], [self._w], [], self._left(deadline))[1]:
                raise TimeoutError
            try:
                n = os.write(self._w, view[:65536])
            except (BrokenPipeError, OSError):
                raise _Gone from None
            view = view[n:]

    def _read(self, n: int, deadline: float | None) -> bytes:
        buf = bytearray()
        while len(buf) < n:
            if not select.select([self._r], [], [], self._left(deadline))[0]:
                raise TimeoutError
            chunk = os.read(self._r, n - len(buf))
            if not chunk:
                raise _Gone
            buf += chunk
        return bytes(buf)

    def _receive(self, deadline: float | None) -> dict[str, Any]:
        (size,) = _HEADER.unpack(self._read(_HEADER.size, deadline))
        if size > MAX_ANSWER:
            raise _Gone
        try:
            answer = json.loads(self._read(size, deadline))
        except (ValueError, RecursionError):
            raise _Gone from None
        if not isinstance(answer, dict):
            raise _Gone
        return answer

    @staticmethod
    def _left(deadline: float | None) -> float | None:
        return None if deadline is None else max(0.0, deadline - time.monotonic())

    def _reap(self) -> str:
        if self.proc is None:
            return "?"
        with contextlib.suppress(subprocess.TimeoutExpired):
            self.proc.wait(timeout=2)
        code = self.proc.returncode
        if code is None:
            return "none: it broke the pipe's protocol"
        return f"{code} (signal {-code})" if code < 0 else str(code)

    def _see_log(self) -> str:
        return f"; its output is in {self.log_path}" if self.log_path is not None else ""


__all__ = ["PROVIDER_KEYS", "PolicyProcess", "harness_entry"]
