"""The folder a ``regen test`` writes: one file per finished case, kept as it finishes.

``DEST/`` holds ``settings.json`` (what the cases were run with), ``cases/<scenario>-v<k>.json``
(one per finished case, written atomically the moment it finishes), ``tests.json`` and
``junit.xml`` (rebuilt from the cases after each one), ``policy.log`` (the policy process's
output; each case file notes which bytes of it were written during that case, which junit.xml
shows with the case), ``<scenario>-v<k>/`` (a failed case's trace and picture) and ``.lock``.

A policy that does not load leaves nothing behind in a folder this command made
(:meth:`ResultsFolder.refused`).

A rerun of the same command resumes: a finished case is kept when its scenario's files are
unchanged, nothing is run twice. A changed policy file or setting starts over (the folder's
own files are removed, with a message); a folder holding anything else is not touched. One
``regen test`` at a time writes a folder (a lock), and the run folder is read under a shared
lock that ``regen generate`` cannot take while a test reads it (nor a test while it writes).
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import re
import shutil
from pathlib import Path
from typing import Any

from regen.core.io import try_lock, write_json
from regen.errors import ConfigError, RegenError
from regen.harness.cases import CaseResult
from regen.harness.pictures import FAILURE_GIF, TRACE_FILE, case_folder
from regen.promises.folders import output_folder
from regen.runfolder import RunFolder, ScenarioFolder, read_json

SETTINGS = "settings.json"
CASES = RunFolder.TEST_CASES
TESTS_JSON = RunFolder.TESTS_JSON
JUNIT = "junit.xml"
POLICY_LOG = "policy.log"
LOCK = ".lock"
RUN_LOCK = RunFolder.LOCK  # regen generate's lock file in the run folder
_CASE_FILE = re.compile(r".+-v\d+\.json")
LOG_TAIL_LINES = 40  # of a case's part of policy.log, in junit.xml
_LOG_TAIL_BYTES = 16384


def case_key(case: CaseResult) -> str:
    return case_folder(case)


def policy_digest(spec: str) -> str | None:
    """sha256 of the policy file a SPEC names (None for a built-in or a module): a rerun with an
    edited file starts over."""
    where = spec.strip()
    if not where.endswith(".py"):
        where = where.rpartition(":")[0]
    if not where.endswith(".py"):
        return None
    try:
        return hashlib.sha256(Path(where).expanduser().read_bytes()).hexdigest()
    except OSError:
        return None


def scenario_digest(folder: Path) -> str:
    """sha256 over a scenario folder's scenario, verdict and trace files (what a case judged;
    :meth:`ScenarioFolder.digest`, which the report compares too)."""
    return ScenarioFolder(folder).digest()


class ResultsFolder:
    """``DEST/`` of one ``regen test``: see the module docstring."""

    def __init__(self, path: str | Path):
        self.path = Path(path).absolute()
        self._fd: int | None = None
        self._run_fd: int | None = None
        self.finished: dict[str, tuple[str, CaseResult]] = {}  # case key -> (scenario digest, case)
        self.created: list[Path] = []  # the folders check() made, deepest first
        self.log_spans: dict[str, tuple[int, int]] = {}  # case key -> its bytes of policy.log
        self._log_at = 0  # where policy.log ended when the last case was kept
        self._tails: dict[str, tuple[tuple[int, int], str]] = {}  # case key -> (span, its tail)

    # --- opening -------------------------------------------------------------------------

    def check(self) -> None:
        """ConfigError when the folder cannot be one (checked before anything runs)."""
        missing, p = [], self.path
        while not p.exists() and not p.is_symlink() and p != p.parent:
            missing.append(p)
            p = p.parent
        output_folder(self.path, give="a folder for tests.json and junit.xml")
        self.created = missing

    def hold_run(self, run: Path) -> None:
        """A shared lock on the run folder: ConfigError while regen generate writes it."""
        try:
            fd, other = try_lock(Path(run) / RUN_LOCK, shared=True)
        except OSError:
            return  # a read-only run folder: nothing can be writing it
        if fd is None:
            raise ConfigError(f"regen generate (pid {other}) is still writing {run}; wait for it to "
                              "finish, then run regen test")
        self._run_fd = fd

    def lock(self) -> None:
        """Hold DEST for this process; ConfigError naming the other one."""
        fd, other = try_lock(self.path / LOCK)
        if fd is None:
            raise ConfigError(f"another regen test (pid {other}) is writing {self.path}; wait for it "
                              "or give another --out")
        self._fd = fd
        self._log_at = self._log_size()  # what the policy prints from now on belongs to the cases

    def refused(self, exc: RegenError) -> RegenError:
        """The error of a policy that did not load, after removing what this command wrote in the
        folder when it made the folder (a bad --policy leaves nothing behind); what the policy
        printed while loading goes into the message then, as its log is gone."""
        self.close()
        if not self.created:
            return exc
        log = self.path / POLICY_LOG
        printed = self._read(log, (0, self._log_size()))
        for name in (POLICY_LOG, LOCK, SETTINGS):
            with contextlib.suppress(FileNotFoundError):
                (self.path / name).unlink()
        for folder in self.created:  # deepest first; one holding anything else stays
            try:
                folder.rmdir()
            except OSError:
                break
        message = str(exc).replace(f"; its output is in {log}", "")
        said = [line.strip() for line in printed.splitlines() if line.strip()][-5:]
        if said:
            message += f"; it printed: {' | '.join(said)}"
        return exc if message == str(exc) else ConfigError(message)

    def _log_size(self) -> int:
        try:
            return (self.path / POLICY_LOG).stat().st_size
        except OSError:
            return 0

    @staticmethod
    def _read(path: Path, span: tuple[int, int]) -> str:
        """The end (at most 16 KiB) of the bytes ``span`` of ``path``, as text."""
        start, end = max(span[0], span[1] - _LOG_TAIL_BYTES), span[1]
        try:
            with open(path, "rb") as f:
                f.seek(start)
                return f.read(max(0, end - start)).decode("utf-8", "replace")
        except OSError:
            return ""

    def log_tails(self) -> dict[str, str]:
        """The last lines the policy printed during each case kept so far, by case key."""
        out = {}
        for key, span in self.log_spans.items():
            cached = self._tails.get(key)
            if cached is None or cached[0] != span:
                lines = self._read(self.path / POLICY_LOG, span).splitlines()[-LOG_TAIL_LINES:]
                cached = self._tails[key] = (span, "\n".join(lines))
            out[key] = cached[1]
        return out

    def close(self) -> None:
        for name in ("_fd", "_run_fd"):
            fd = getattr(self, name)
            if fd is not None:
                with contextlib.suppress(OSError):
                    os.close(fd)
                setattr(self, name, None)

    def open(self, settings: dict[str, Any]) -> str | None:
        """Lock DEST (unless :meth:`lock` did) and load the cases a rerun keeps; a message when it
        starts over."""
        if self._fd is None:
            self.lock()
        stored = read_json(self.path / SETTINGS).value
        note = None
        has_cases = (self.path / CASES).is_dir() and any((self.path / CASES).iterdir())
        if stored != settings and (has_cases or stored is not None):
            changed = sorted(k for k in set(settings) | set(stored or {})
                             if (stored or {}).get(k) != settings.get(k))
            what = ", ".join("the policy file" if k == "policy_digest" else k for k in changed)
            note = (f"{self.path}: {what or 'the settings'} changed since its last run; starting over "
                    f"(its cases are removed)")
            self._clear()
        write_json(self.path / SETTINGS, settings)
        for f in sorted((self.path / CASES).glob("*.json")) if (self.path / CASES).is_dir() else []:
            raw = read_json(f).value
            try:
                case = CaseResult.model_validate(raw["case"])
                digest = str(raw["digest"])
            except (TypeError, KeyError, ValueError):
                continue  # a damaged case file: the case runs again
            self.finished[case_key(case)] = (digest, case)
            span = raw.get("log")
            if (isinstance(span, list) and len(span) == 2 and all(type(n) is int for n in span)
                    and 0 <= span[0] < span[1]):
                self.log_spans[case_key(case)] = (span[0], span[1])
        if any(end > self._log_size() for _, end in self.log_spans.values()):
            self.log_spans.clear()  # policy.log was replaced since: its old parts are unknown
        return note

    def _clear(self) -> None:
        """Remove this folder's own files of an earlier run (case files, results, failure
        folders holding only a trace and a picture); nothing else."""
        cases = self.path / CASES
        if cases.is_dir():
            for f in cases.iterdir():
                if f.is_file() and _CASE_FILE.fullmatch(f.name):
                    f.unlink()
            with contextlib.suppress(OSError):
                cases.rmdir()
        for name in (TESTS_JSON, JUNIT, SETTINGS):
            with contextlib.suppress(FileNotFoundError):
                (self.path / name).unlink()
        for d in self.path.iterdir():
            if d.is_dir() and re.fullmatch(r".+-v\d+", d.name):
                self.drop_failure_files(d.name)

    # --- cases ---------------------------------------------------------------------------

    def reuse(self, key: str, digest: str) -> CaseResult | None:
        """The finished case of an earlier run of the same command, when its scenario is unchanged
        (a case that could not be run is not kept: the rerun tries it again)."""
        found = self.finished.get(key)
        if found is None or found[0] != digest or found[1].cause == "error":
            return None  # a case that could not run is tried again
        return found[1]

    def keep(self, case: CaseResult, digest: str) -> None:
        """Write one finished case (atomically) with the bytes of policy.log written since the last
        one (a case kept from an earlier run keeps its own); a passed case's old failure files go."""
        key = case_key(case)
        found = self.finished.get(key)
        if found is not None and found[1] is case:
            span = self.log_spans.get(key)
        else:
            end = self._log_size()
            span = (self._log_at, end) if end > self._log_at else None
            self._log_at = max(self._log_at, end)
        if span is None:
            self.log_spans.pop(key, None)
        else:
            self.log_spans[key] = span
        write_json(self.path / CASES / f"{key}.json",
                   {"digest": digest, "case": case.model_dump(mode="json"),
                    **({"log": list(span)} if span is not None else {})})
        if case.status != "failed":
            self.drop_failure_files(case_key(case))

    def drop_failure_files(self, name: str) -> None:
        """Remove ``DEST/<name>/`` when it holds only what a failed case leaves."""
        d = self.path / name
        if not d.is_dir():
            return
        entries = {p.name for p in d.iterdir()}
        if entries <= {TRACE_FILE, FAILURE_GIF}:
            shutil.rmtree(d, ignore_errors=True)

    def write(self, report: Any) -> dict[str, Path]:
        """tests.json and junit.xml of the cases so far."""
        from regen.harness.junit import write_report

        return write_report(report, self.path, logs=self.log_tails())


__all__ = ["CASES", "JUNIT", "POLICY_LOG", "SETTINGS", "TESTS_JSON", "ResultsFolder", "case_key",
           "policy_digest", "scenario_digest"]
