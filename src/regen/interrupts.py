"""Ctrl-C during a run: never lost, and never unwinding a simulator mid-step."""

from __future__ import annotations

import contextlib
import logging
import signal
import threading
from collections.abc import Iterator
from typing import Any

log = logging.getLogger(__name__)


class Interrupts:
    """Ctrl-C that is never lost: Python raises KeyboardInterrupt wherever the main thread is,
    and one that lands in a finalizer (simulators run many generators) is only printed as
    'Exception ignored'. The handler also sets a flag, and the pipeline checks it between steps.

    Within :meth:`deferred` (a simulation in this process) the first Ctrl-C only sets the flag:
    the scenario finishes and is kept, then the run stops; a simulator's C code is never unwound
    mid-step (an interrupt there once ended a run with a segmentation fault, nothing saved).
    A second Ctrl-C stops at once."""

    def __init__(self) -> None:
        self.seen = False
        self._old: Any = None
        self._defer = False

    def _handler(self, signum: int, frame: Any) -> None:
        if self._defer and not self.seen:
            self.seen = True
            log.warning("Ctrl-C: finishing the current scenario (kept), then stopping; "
                        "press Ctrl-C again to stop at once")
            return
        self.seen = True
        raise KeyboardInterrupt

    @contextlib.contextmanager
    def deferred(self) -> Iterator[None]:
        """A step that a first Ctrl-C lets finish (the run stops right after it)."""
        self._defer = True
        try:
            yield
        finally:
            self._defer = False

    def __enter__(self) -> Interrupts:
        if threading.current_thread() is threading.main_thread() and \
                signal.getsignal(signal.SIGINT) is signal.default_int_handler:
            self._old = signal.signal(signal.SIGINT, self._handler)
        return self

    def __exit__(self, *exc: object) -> None:
        if self._old is not None:
            signal.signal(signal.SIGINT, self._old)

    def check(self) -> None:
        if self.seen:
            raise KeyboardInterrupt


__all__ = ["Interrupts"]
