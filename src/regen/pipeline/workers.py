"""Set-up of a simulation worker process (:mod:`regen.pipeline.tasks`)."""

from __future__ import annotations

import os
import signal


def worker_init(parent: int) -> None:
    """In a simulation worker: die with the main process (a killed run leaves no worker behind,
    writing into its folder), and leave Ctrl-C to the main process, which stops the pool."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        PR_SET_PDEATHSIG = 1  # Linux prctl option
        libc.prctl(PR_SET_PDEATHSIG, signal.SIGKILL)
    except (OSError, AttributeError):  # not Linux: workers end when the pool's pipe closes
        pass
    if os.getppid() != parent:  # the main process died before prctl took effect
        os._exit(1)


__all__ = ["worker_init"]
