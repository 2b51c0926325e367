"""``RUN/``: the run folder (:class:`RunFolder`): its manifest, graph, model cache, events, report
and scenario folders; opening it for writing (a lock, and a resume only with the settings that
made the run); and the readers of what a finished or half-finished run holds (:func:`list_runs`,
:func:`read_summary`, :func:`read_graph`, :func:`read_tests`, :func:`read_falsify`), which never
raise for a missing or broken file."""

from __future__ import annotations

import contextlib
import os
import shutil
from collections.abc import Iterator
from pathlib import Path
from typing import Any, ClassVar

from regen.core.behavior import Behavior
from regen.core.graph import ScenarioGraph
from regen.core.io import try_lock, write_json
from regen.core.scenario import Scenario
from regen.core.verdict import Verdict
from regen.errors import RunError
from regen.promises.folders import output_folder
from regen.runfolder.fresh import fresh_plan
from regen.runfolder.manifest import RunManifest, RunSettings, now
from regen.runfolder.readers import Loaded, read_json, read_model
from regen.runfolder.scenario import ScenarioFolder


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
    FALSIFY = "falsify"  # regen falsify: RUN/falsify/<policy>/falsify.json and its candidates
    FALSIFY_JSON = "falsify.json"
    #: Top-level entries a run keeps over ``--fresh``: the lock, the model cache (answers are keyed
    #: by model and prompt, so they stay valid), and other commands' results in the run:
    #: ``regen test``'s, ``regen whatif``'s, ``regen augment``'s and ``regen falsify``'s.
    KEPT: ClassVar[tuple[str, ...]] = (LOCK, CACHE, f"{CACHE}-wal", f"{CACHE}-shm", f"{CACHE}-journal",
                                       TESTS, WHATIF, AUGMENT, FALSIFY)

    def clear(self) -> None:
        """Remove the run's results for a fresh start: only what a run wrote, and nothing at
        all when the folder holds anything else (:func:`regen.runfolder.fresh.fresh_plan`)."""
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


def _per_policy(run: Path, section: str, file: str) -> dict[str, Loaded]:
    """``RUN/<section>/<policy>/<file>`` of every policy folder that holds one, as a JSON object,
    sorted by name; a broken file gives a problem, never an exception; none without the folder."""
    base = Path(run) / section
    try:
        found = sorted(p for p in base.iterdir() if (p / file).exists())
    except OSError:  # no such folder (or an unreadable one): nothing
        return {}
    out = {}
    for p in found:
        got = read_json(p / file)
        out[p.name] = got if not got.ok or isinstance(got.value, dict) else Loaded(
            problem="unreadable: not a JSON object")
    return out


def read_tests(run: Path) -> dict[str, Loaded]:
    """Behavior-test results of a run (``regen test``): policy folder name -> its
    ``tests/<policy>/tests.json`` (see :func:`_per_policy`)."""
    return _per_policy(run, RunFolder.TESTS, RunFolder.TESTS_JSON)


def read_falsify(run: Path) -> dict[str, Loaded]:
    """Falsification results of a run (``regen falsify``): policy folder name -> its
    ``falsify/<policy>/falsify.json`` (see :func:`_per_policy`)."""
    return _per_policy(run, RunFolder.FALSIFY, RunFolder.FALSIFY_JSON)


def behavior_test_name(scenario: str, variant: int | str) -> str:
    """The name of one behavior test's files beside tests.json (its result in
    ``RunFolder.TEST_CASES``, its failure pictures): ``<scenario>-v<variant>``."""
    return f"{scenario}-v{variant}"



__all__ = ["RunFolder", "behavior_test_name", "list_runs", "read_falsify", "read_graph", "read_summary",
           "read_tests"]
