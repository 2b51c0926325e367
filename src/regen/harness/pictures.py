"""What a failed test leaves beside ``tests.json``: ``<scenario>-v<variant>/trace.json`` (the
policy's episode) and a picture of it drawn by the domain (``failure.gif``)."""

from __future__ import annotations

import logging
from collections.abc import Callable
from pathlib import Path
from typing import Any

from regen.core.io import write_json
from regen.harness.cases import CaseResult
from regen.harness.contract import Episode, PolicyHarness
from regen.runfolder import behavior_test_name

log = logging.getLogger(__name__)

FAILURE_GIF = "failure.gif"
TRACE_FILE = "trace.json"


def case_folder(case: CaseResult) -> str:
    """Folder name of one test's files beside tests.json: ``<scenario>-v<variant>``."""
    return behavior_test_name(case.scenario, case.variant)


def keep_failures(out_dir: str | Path, harness: PolicyHarness, *, policy: str = "policy",
                  pictures: bool = True) -> Callable[[CaseResult, Episode, Any], None]:
    """An ``on_episode`` callback for :func:`regen.harness.suite.run_tests`: for each failed
    test with an episode, write ``trace.json`` and (with ``pictures``) the harness's picture
    into ``out_dir/<scenario>-v<variant>/`` and set the case's ``gif`` to its path relative to
    ``out_dir`` (where tests.json goes). A picture that cannot be drawn is logged, never a
    failed test."""
    out = Path(out_dir)

    def on_episode(case: CaseResult, episode: Episode, prepared: Any) -> None:
        if case.status != "failed" or episode.trace is None or episode.trace.steps == 0:
            return
        folder = out / case_folder(case)
        folder.mkdir(parents=True, exist_ok=True)
        write_json(folder / TRACE_FILE, episode.trace)
        if not pictures:
            return
        try:
            gif = harness.failure_picture(prepared.scenario, episode, prepared, case, policy,
                                          folder / FAILURE_GIF)
        except Exception as exc:  # noqa: BLE001 - a missing picture must not fail or stop the tests
            log.warning("no picture of the failed test %s: %s: %s", case_folder(case), type(exc).__name__, exc)
            return
        if gif is not None:
            case.gif = Path(gif).relative_to(out).as_posix()

    return on_episode


__all__ = ["FAILURE_GIF", "TRACE_FILE", "case_folder", "keep_failures"]
