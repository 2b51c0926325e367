"""The policy's own process: ``python -m regen.harness.worker HARNESS SPEC READ_FD WRITE_FD``.

Started by :class:`regen.harness.process.PolicyProcess`. It imports the domain's harness
(``module:Class``), loads the user's policy SPEC with it, and then answers the harness's
requests until the pipe closes: ``("reset", None)`` and ``("act", observation)``. Requests
arrive pickled (the harness is trusted here); answers leave as JSON (the harness trusts
nothing this process says): ``{"ready": true}``, ``{"config": message}`` when the policy does
not load, ``{"ok": null}`` after a reset, ``{"action": data}`` with the action converted to
plain numbers *here* (a slow ``__float__`` is the policy's time, under the harness's clock),
``{"invalid": message}`` when it cannot be, ``{"exception": message}`` when the policy raised
anything, BaseException included.

Whatever the policy does (exit, hang, start threads, change directory, patch modules) happens
in this process only; the harness kills it at the step timeout.
"""

from __future__ import annotations

import importlib
import json
import os
import pickle
import struct
import sys
from typing import Any

_HEADER = struct.Struct(">I")
MAX_TEXT = 2000  # characters of a message taken from the policy's exception


def _read_exact(fd: int, n: int) -> bytes | None:
    buf = bytearray()
    while len(buf) < n:
        chunk = os.read(fd, n - len(buf))
        if not chunk:
            return None
        buf += chunk
    return bytes(buf)


def _send(fd: int, message: dict[str, Any]) -> None:
    data = json.dumps(message, allow_nan=False).encode()
    payload = _HEADER.pack(len(data)) + data
    while payload:
        payload = payload[os.write(fd, payload):]


def _describe(exc: BaseException) -> str:
    try:
        text = str(exc)
    except BaseException:  # noqa: BLE001 - a policy's exception may fail to print itself
        text = "(its message could not be printed)"
    text = f"{type(exc).__name__}: {text}" if text else type(exc).__name__
    return text if len(text) <= MAX_TEXT else text[:MAX_TEXT] + "..."


def _harness(entry: str) -> Any:
    module, _, name = entry.partition(":")
    obj: Any = importlib.import_module(module)
    for part in name.split("."):
        obj = getattr(obj, part)
    return obj()


def serve(entry: str, spec: str, rfd: int, wfd: int) -> int:
    """Load the policy and answer requests until the harness closes the pipe."""
    try:
        harness = _harness(entry)
        policy = harness.load_policy(spec)
    except BaseException as exc:  # noqa: BLE001 - a bad SPEC or a policy module that raises
        from regen.errors import RegenError

        text = str(exc) if isinstance(exc, RegenError) else f"loading policy {spec} failed: {_describe(exc)}"
        _send(wfd, {"config": text[:MAX_TEXT]})
        return 2
    _send(wfd, {"ready": True})
    while True:
        head = _read_exact(rfd, _HEADER.size)
        if head is None:
            return 0
        body = _read_exact(rfd, _HEADER.unpack(head)[0])
        if body is None:
            return 0
        op, payload = pickle.loads(body)
        try:
            if op == "reset":
                reset = getattr(policy, "reset", None)
                if callable(reset):
                    reset()
                answer: dict[str, Any] = {"ok": None}
            else:
                raw = policy(payload)
                try:
                    answer = {"action": harness.action_to_wire(raw)}
                    json.dumps(answer, allow_nan=False)
                except BaseException as exc:  # noqa: BLE001 - anything the action's methods raise
                    answer = {"invalid": _describe(exc) if not isinstance(exc, ValueError) else str(exc)[:MAX_TEXT]}
        except BaseException as exc:  # noqa: BLE001 - SystemExit and KeyboardInterrupt included
            answer = {"exception": _describe(exc)}
        _send(wfd, answer)


def main(argv: list[str]) -> int:
    if len(argv) != 5:
        print("usage: python -m regen.harness.worker HARNESS SPEC READ_FD WRITE_FD (started by regen test)",
              file=sys.stderr)
        return 2
    entry, spec, rfd, wfd = argv[1], argv[2], int(argv[3]), int(argv[4])
    sys.stdin = open(os.devnull)  # noqa: SIM115 - the policy reads no terminal input
    code = serve(entry, spec, rfd, wfd)
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)  # threads the policy left running do not keep this process alive


if __name__ == "__main__":
    main(sys.argv)
