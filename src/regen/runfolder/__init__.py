"""The run folder: one package that lays it out, writes it, reads it and decides how to resume it.

The pipeline, the report, evaluation and the CLI all go through this package (layout and
guarantees: docs/run-folder.md). Writes are atomic (temporary file + rename); a scenario is
finished when its ``verdict.json`` exists, which is written last; ``run.json`` says ``done``
only after everything else of the run is on disk. A folder is used by one process at a time
(a lock file), and a rerun resumes only with the settings that made the run: a result-changing
difference stops with a message, unless the user asks for a fresh start.

Readers never raise for a missing or broken file: they return a :class:`Loaded` with the
problem, so a half-finished or hand-edited run can still be shown (:mod:`.readers`).
``run.json`` is :mod:`.manifest`; what ``--fresh`` may remove is :mod:`.fresh`.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import shutil
from collections.abc import Collection, Iterator
from pathlib import Path
from typing import Any, ClassVar

from regen.core.behavior import Behavior
from regen.core.graph import CausePath, ScenarioGraph
from regen.core.io import atomic_write_text, try_lock, write_json
from regen.core.scenario import Scenario
from regen.core.trace import Trace
from regen.core.verdict import Verdict
from regen.errors import RunError
from regen.promises.folders import entries, is_temp_of, output_folder
from regen.runfolder.manifest import RunManifest, RunSettings, merge_usage, now
from regen.runfolder.readers import (
    MAX_JSON_BYTES,
    MAX_TEXT_CHARS,
    Loaded,
    read_json,
    read_model,
    read_text,
)

# --- one scenario folder -------------------------------------------------------------------------


class ScenarioFolder:
    """``RUN/scenarios/<name>/``: one cause chain's files."""

    PATH = "path.json"
    SCENARIO = "scenario.json"
    TRACE = "trace.json"
    VERDICT = "verdict.json"
    TIMINGS = "timings.json"
    FILES = "files.json"
    ERROR = "error.txt"
    #: the names of what the domain's steps (simulate, render, export) wrote here, beside the
    #: folder's own files: what ``--fresh`` may remove (:mod:`.fresh`)
    WRITTEN = "written.json"
    #: the files every scenario folder may hold, by name
    OWN: ClassVar[tuple[str, ...]] = (PATH, SCENARIO, TRACE, VERDICT, TIMINGS, FILES, ERROR, WRITTEN)

    def __init__(self, path: Path):
        self.path = Path(path)
        self.name = self.path.name

    def __truediv__(self, name: str) -> Path:
        return self.path / name

    def digest(self) -> str:
        """sha256 over the scenario, verdict and trace files: what a behavior test judged, so a
        test result can tell whether its scenario is still the one it ran ('-' for a missing file)."""
        h = hashlib.sha256()
        for name in (self.SCENARIO, self.VERDICT, self.TRACE):
            try:
                h.update((self.path / name).read_bytes())
            except OSError:
                h.update(b"-")
            h.update(b"\0")
        return h.hexdigest()

    # readers
    def verdict(self) -> Verdict | None:
        """The verdict if the scenario finished (a broken verdict counts as unfinished)."""
        return read_model(self / self.VERDICT, Verdict).value

    def scenario(self) -> Scenario | None:
        return read_model(self / self.SCENARIO, Scenario, key="scenario").value

    def holds(self, path: CausePath) -> bool:
        """Whether the folder was made for ``path`` (a resume reuses nothing else)."""
        got = read_model(self / self.PATH, CausePath)
        # compared as JSON: a behavior's parameters read back hold lists where the fresh path may
        # hold tuples (a recorded trajectory's poses), the same path all the same
        return got.ok and got.value.model_dump(mode="json") == path.model_dump(mode="json")

    def timings(self) -> dict[str, float]:
        raw = read_json(self / self.TIMINGS)
        if not raw.ok or not isinstance(raw.value, dict):
            return {}
        return {str(k): float(v) for k, v in raw.value.items()
                if isinstance(v, (int, float)) and not isinstance(v, bool)}

    def files(self) -> dict[str, str]:
        """Role -> file name of what the domain's render/export wrote (only names inside the folder)."""
        raw = read_json(self / self.FILES)
        if not raw.ok or not isinstance(raw.value, dict):
            return {}
        return {str(k): str(v) for k, v in raw.value.items()
                if isinstance(v, str) and Path(v).name == v and (self / v).is_file()}

    def written(self) -> set[str]:
        """The names of what the run wrote here beyond :attr:`OWN`: those ``written.json`` lists
        and those ``files.json`` lists (a run made before ``written.json`` was kept has only
        these); plain names only, whether or not they still exist."""
        names: set[str] = set()
        for name, want in ((self.WRITTEN, list), (self.FILES, dict)):
            raw = read_json(self / name)
            if raw.ok and isinstance(raw.value, want):
                names.update(v for v in (raw.value.values() if want is dict else raw.value)
                             if isinstance(v, str) and v and Path(v).name == v and v not in (".", ".."))
        return names

    def foreign(self, known: Collection[str] = ()) -> list[str]:
        """The entries of the folder the run did not write (``/`` after a folder's name): not
        among :attr:`OWN`, :meth:`written` or ``known`` (names the run wrote into its other
        scenario folders), nor a temporary file of an atomic write of one of them."""
        own = {*self.OWN, *self.written(), *known}
        return [p.name + ("/" if p.is_dir() and not p.is_symlink() else "")
                for p in entries(self.path, error=RunError)
                if p.name not in own and not is_temp_of(p.name, own)]

    # writers (each atomic)
    def record_written(self, names: Collection[str]) -> None:
        """Add ``names`` (entries of this folder) to ``written.json``."""
        new = {n for n in names if Path(n).name == n and n not in self.OWN} - self.written()
        if new:
            raw = read_json(self / self.WRITTEN)
            old = raw.value if raw.ok and isinstance(raw.value, list) else []
            write_json(self / self.WRITTEN, sorted({*(v for v in old if isinstance(v, str)), *new}))

    @contextlib.contextmanager
    def recording(self) -> Iterator[None]:
        """Record in ``written.json`` every entry that appears in the folder while the block
        runs (a domain's simulate, render and export steps write files the toolkit does not
        name), even when the block fails."""
        def names() -> set[str]:
            try:
                return {p.name for p in self.path.iterdir()}
            except OSError:
                return set()

        before = names()
        failed = False
        try:
            yield
        except BaseException:
            failed = True
            raise
        finally:
            appeared = {n for n in names() - before if not n.endswith(".tmp")}
            try:
                self.record_written(appeared)
            except OSError:
                if not failed:  # a full disk: the block's own error is the one to tell
                    raise

    def start(self, path: CausePath) -> None:
        self.path.mkdir(parents=True, exist_ok=True)
        write_json(self / self.PATH, path)

    def write_scenario(self, scenario: Scenario, config: dict) -> None:
        write_json(self / self.SCENARIO, {"scenario": scenario.model_dump(mode="json"), "config": config})

    def write_trace(self, trace: Trace) -> None:
        write_json(self / self.TRACE, trace)

    def add_timings(self, timings: dict[str, float]) -> None:
        write_json(self / self.TIMINGS, {**self.timings(), **timings})

    def add_files(self, files: dict[str, Path]) -> None:
        """Record role -> file written by the domain (paths outside the folder are refused), and
        the files as written by the run."""
        known = self.files()
        for role, p in files.items():
            p = Path(p)
            if p.parent.resolve() != self.path.resolve():
                raise RunError(f"{p} is outside the scenario folder {self.path}; a domain writes "
                               "its files into the folder it is given")
            known[role] = p.name
        self.record_written(known.values())
        write_json(self / self.FILES, known)

    def write_error(self, text: str) -> None:
        atomic_write_text(self / self.ERROR, text)

    def write_verdict(self, verdict: Verdict) -> None:
        """Last: a scenario with a verdict is finished."""
        write_json(self / self.VERDICT, verdict)

    def reset(self, *, grounding: bool = False) -> None:
        """Remove what an unfinished attempt left (kept: path.json, scenario.json and the
        grounding's timings, unless ``grounding`` is to be redone as well)."""
        names = [self.TRACE, self.VERDICT, self.FILES, self.ERROR]
        if grounding:
            names += [self.PATH, self.SCENARIO, self.TIMINGS]
        for name in names:
            (self / name).unlink(missing_ok=True)


# --- the run folder ------------------------------------------------------------------------------


class RunFolder:
    """``RUN/``: the manifest, the graph, the model cache, events, report and scenario folders."""

    MANIFEST = "run.json"
    GRAPH = "graph.json"
    CACHE = "llm-cache.sqlite"
    EVENTS = "events.jsonl"
    SUMMARY = "summary.json"
    REPORT = "report.html"
    LOCK = ".lock"
    SCENARIOS = "scenarios"
    TESTS = "tests"  # regen test: tests/<policy>/tests.json, junit.xml and failure pictures
    TESTS_JSON = "tests.json"
    TEST_CASES = "cases"  # regen test: tests/<policy>/cases/<scenario>-v<k>.json, one result each

    def __init__(self, path: str | Path):
        self.path = Path(path)
        self._lock_fd: int | None = None

    def __truediv__(self, name: str) -> Path:
        return self.path / name

    @property
    def cache_path(self) -> Path:
        return self / self.CACHE

    def scenario(self, name: str) -> ScenarioFolder:
        if not name or Path(name).name != name or name in (".", ".."):
            raise RunError(f"{name!r} is not a scenario folder name")
        return ScenarioFolder(self / self.SCENARIOS / name)

    def scenario_names(self) -> list[str]:
        """Folder names in run order: those run.json lists, then any others on disk (sorted)."""
        base = self / self.SCENARIOS
        try:
            on_disk = sorted(p.name for p in base.iterdir() if p.is_dir()) if base.is_dir() else []
        except OSError:
            on_disk = []
        listed = self.read_manifest_raw().value
        names = listed.get("scenarios") if isinstance(listed, dict) else None
        order = [str(n) for n in names if str(n) in on_disk] if isinstance(names, list) else []
        order = list(dict.fromkeys(order))
        return order + [n for n in on_disk if n not in order]

    def scenarios_of(self, domain: str) -> Iterator[tuple[str, ScenarioFolder, Scenario, Verdict | None]]:
        """(folder name, folder, scenario, verdict or None while unfinished) of every readable
        ``domain`` scenario, in run order: what behavior tests and training envs run on."""
        for name in self.scenario_names():
            folder = self.scenario(name)
            scenario = folder.scenario()
            if scenario is not None and scenario.domain == domain:
                yield name, folder, scenario, folder.verdict()

    # --- manifest ----------------------------------------------------------------------------

    def read_manifest_raw(self) -> Loaded:
        raw = read_json(self / self.MANIFEST)
        if raw.ok and not isinstance(raw.value, dict):
            return Loaded(problem="unreadable: not a JSON object")
        return raw

    def read_manifest(self) -> RunManifest:
        """The manifest; RunError saying what to do when it is missing or unreadable."""
        got = read_model(self / self.MANIFEST, RunManifest)
        if got.problem == "missing":
            raise RunError(f"{self.path} is not a run folder (no run.json)")
        if not got.ok:  # never advise --fresh here: the folder may not be a run at all
            raise RunError(f"{self / self.MANIFEST} is {got.problem}; regen does not overwrite a "
                           f"folder it cannot read: repair that file, or move {self.path} aside, or "
                           "give `regen generate` another --out")
        return got.value

    def write_manifest(self, manifest: RunManifest) -> None:
        write_json(self / self.MANIFEST, manifest)

    def record_failure(self, manifest: RunManifest) -> bool:
        """Write the manifest of a run that stops because the disk took no more: atomically if
        possible, else over the old run.json in place (a full disk has no room for a temporary
        file, but the old file's blocks are reused). Returns whether it was written."""
        try:
            self.write_manifest(manifest)
            return True
        except OSError:
            pass
        data = (manifest.model_dump_json(indent=2) + "\n").encode("utf-8")
        try:
            with open(self / self.MANIFEST, "r+b") as fh:  # not truncated first: blocks kept
                fh.write(data)
                fh.truncate(len(data))
            return True
        except OSError:
            return False

    def is_run(self) -> bool:
        return (self / self.MANIFEST).is_file()

    # --- opening for writing -----------------------------------------------------------------

    def _check_writable(self) -> None:
        output_folder(self.path, give="a folder (new or an earlier run's)", what="the run folder",
                      error=RunError)

    def _read_or_rebuild(self, behavior: Behavior, settings: RunSettings,
                         domain_settings: dict[str, str | None]) -> tuple[RunManifest, str]:
        """The stored manifest; an unreadable one is rebuilt when graph.json shows the same
        behavior (finished scenarios are then reused only where their path.json matches)."""
        try:
            return self.read_manifest(), ""
        except RunError as exc:
            graph = read_graph(self.path)
            if not graph.ok or (graph.value.behavior.text, graph.value.behavior.domain) != (
                    behavior.text, behavior.domain):
                raise
            note = f"run.json was unreadable ({exc}); rebuilt from graph.json with this command's settings"
            return RunManifest(behavior=behavior, settings=settings, domain_settings=domain_settings,
                               started=now()), note

    def lock(self) -> None:
        """Hold the folder for this process; RunError naming the other process if it is taken."""
        fd, other = try_lock(self / self.LOCK)
        if fd is None:
            raise RunError(f"another regen process (pid {other}) is working on {self.path}; wait "
                           "for it to finish or choose another --out")
        self._lock_fd = fd

    def unlock(self) -> None:
        if self._lock_fd is not None:
            os.close(self._lock_fd)  # closing releases the lock
            self._lock_fd = None

    #: Top-level files a run writes; ``--fresh`` removes them (and their temporary files).
    RUN_FILES: ClassVar[tuple[str, ...]] = (MANIFEST, GRAPH, "graph.png", "graph.html", EVENTS, SUMMARY,
                                            REPORT)
    WHATIF = "whatif"  # regen whatif: RUN/whatif/<scenario>-whatif-<hash>/ and its model cache
    AUGMENT = "augment"  # regen augment: RUN/augment/<scenario>-augment/ and its model cache
    #: Top-level entries a run keeps over ``--fresh``: the lock, the model cache (answers are keyed
    #: by model and prompt, so they stay valid), and other commands' results in the run:
    #: ``regen test``'s, ``regen whatif``'s and ``regen augment``'s.
    KEPT: ClassVar[tuple[str, ...]] = (LOCK, CACHE, f"{CACHE}-wal", f"{CACHE}-shm", f"{CACHE}-journal",
                                       TESTS, WHATIF, AUGMENT)

    def clear(self) -> None:
        """Remove the run's results for a fresh start: only what a run wrote, and nothing at
        all when the folder holds anything else (:func:`regen.runfolder.fresh.fresh_plan`)."""
        from regen.runfolder.fresh import fresh_plan

        plan = fresh_plan(self)
        for p in plan.files:
            if p.is_dir() and not p.is_symlink():  # a folder a domain's step wrote, as written.json says
                shutil.rmtree(p)
            else:
                p.unlink(missing_ok=True)
        for p in plan.folders:
            with contextlib.suppress(OSError):
                p.rmdir()  # empty now; a file that appeared meanwhile keeps it

    def open(self, behavior: Behavior, settings: RunSettings, domain_settings: dict[str, str | None],
             *, fresh: bool = False) -> RunManifest:
        """Lock the folder and return the manifest to run under: a new one, or the stored one
        when this is a resume with the same behavior and result-changing settings."""
        self._check_writable()
        had_lock = (self / self.LOCK).exists()
        self.lock()
        try:
            return self._open(behavior, settings, domain_settings, fresh)
        except BaseException as exc:
            if isinstance(exc, RunError) and not had_lock:  # a refused folder keeps nothing of ours
                (self / self.LOCK).unlink(missing_ok=True)
            self.unlock()
            raise

    def _open(self, behavior: Behavior, settings: RunSettings, domain_settings: dict[str, str | None],
              fresh: bool) -> RunManifest:
        if fresh:
            self.clear()
        if not self.is_run():
            return RunManifest(behavior=behavior, settings=settings,
                               domain_settings=domain_settings, started=now())
        old, note = self._read_or_rebuild(behavior, settings, domain_settings)
        if (old.behavior.text, old.behavior.domain) != (behavior.text, behavior.domain):
            raise RunError(f"{self.path} holds a run of another behavior ('{old.behavior.text}', "
                           f"{old.behavior.domain}); use another --out folder, or --fresh to "
                           "replace it (only the run's files are removed)")
        diffs = [f"{k}: {getattr(old.settings, k)!r} then, {getattr(settings, k)!r} now"
                 for k in RunSettings.RESULT_FIELDS if getattr(old.settings, k) != getattr(settings, k)]
        diffs += [f"{k}: {old.domain_settings.get(k)!r} then, {v!r} now"
                  for k, v in domain_settings.items() if old.domain_settings.get(k) != v]
        if diffs:
            raise RunError(f"{self.path} was made with other settings ({'; '.join(diffs)}); "
                           "rerun with the same options to resume it, add --fresh to start over "
                           "(the model cache is kept), or use another --out")
        return old.model_copy(update={"status": "running", "finished": None, "message": note,
                                      "settings": settings})


def list_runs(root: Path) -> list[tuple[Path, RunManifest | None, str | None]]:
    """Run folders under ``root`` (or ``root`` itself), newest first, as (path, manifest or
    None, problem or None): a broken run.json is listed with its problem, never raised."""
    root = Path(root)
    found = [root] if (root / RunFolder.MANIFEST).exists() else sorted(
        p.parent for p in root.glob(f"*/{RunFolder.MANIFEST}"))
    out = []
    for p in found:
        got = read_model(p / RunFolder.MANIFEST, RunManifest)
        out.append((p, got.value, got.problem))
    return sorted(out, key=lambda x: x[1].started if x[1] else "", reverse=True)


def read_summary(run: Path) -> dict[str, Any] | None:
    got = read_json(Path(run) / RunFolder.SUMMARY)
    return got.value if got.ok and isinstance(got.value, dict) else None


def read_graph(run: Path) -> Loaded:
    return read_model(Path(run) / RunFolder.GRAPH, ScenarioGraph)


def read_tests(run: Path) -> dict[str, Loaded]:
    """Behavior-test results of a run (``regen test``): policy folder name -> its
    ``tests/<policy>/tests.json`` as a JSON object, sorted by name; a broken file gives a
    problem, never an exception."""
    base = Path(run) / RunFolder.TESTS
    try:
        found = sorted(p for p in base.iterdir() if (p / RunFolder.TESTS_JSON).exists())
    except OSError:  # no tests/ folder (or an unreadable one): no behavior tests
        return {}
    out = {}
    for p in found:
        got = read_json(p / RunFolder.TESTS_JSON)
        out[p.name] = got if not got.ok or isinstance(got.value, dict) else Loaded(
            problem="unreadable: not a JSON object")
    return out


def behavior_test_name(scenario: str, variant: int | str) -> str:
    """The name of one behavior test's files beside tests.json (its result in
    ``RunFolder.TEST_CASES``, its failure pictures): ``<scenario>-v<variant>``."""
    return f"{scenario}-v{variant}"


__all__ = ["MAX_JSON_BYTES", "MAX_TEXT_CHARS", "Loaded", "RunFolder", "RunManifest", "RunSettings",
           "ScenarioFolder", "behavior_test_name", "list_runs", "merge_usage", "now",
           "read_graph", "read_json", "read_model", "read_summary", "read_tests", "read_text"]
