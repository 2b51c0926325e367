"""The run folder: one module that lays it out, writes it, reads it and decides how to resume it.

The pipeline, the report, evaluation and the CLI all go through this module (layout and
guarantees: docs/run-folder.md). Writes are atomic (temporary file + rename); a scenario is
finished when its ``verdict.json`` exists, which is written last; ``run.json`` says ``done``
only after everything else of the run is on disk. A folder is used by one process at a time
(a lock file), and a rerun resumes only with the settings that made the run: a result-changing
difference stops with a message, unless the user asks for a fresh start.

Readers never raise for a missing or broken file: they return a :class:`Loaded` with the
problem, so a half-finished or hand-edited run can still be shown.
"""

from __future__ import annotations

import datetime as dt
import json
import os
import shutil
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar, TypeVar

from pydantic import BaseModel, Field, ValidationError

from regen.core.base import Model
from regen.core.behavior import Behavior
from regen.core.graph import CausePath, ScenarioGraph
from regen.core.io import atomic_write_text, write_json
from regen.core.scenario import Scenario
from regen.core.trace import Trace
from regen.core.verdict import Verdict
from regen.errors import RunError
from regen.expand.expansion import Limits

M = TypeVar("M", bound=BaseModel)

MAX_JSON_BYTES = 50_000_000  # larger files are not parsed by readers (a trace can be big)
MAX_TEXT_CHARS = 20_000  # error.txt beyond this is cut when read for display

_LIMITS = Limits()  # the one place for expansion defaults; the settings below take them from it


class RunSettings(Model):
    """How a run was made. Defaults are those of the main job (``regen generate``)."""

    llm: str = "local"
    depth: int = _LIMITS.max_depth  # event layers behind the behavior
    max_nodes: int = _LIMITS.max_nodes  # accepted cause events
    max_scenarios: int = 3
    causes: int = _LIMITS.max_causes  # candidates per proposal call
    max_entities: int = _LIMITS.max_entities  # entities kept per event
    prior: str | None = None
    candidates: list[str] = Field(default_factory=list)  # causes of the behavior to judge too
    forced_causes: list[str] = Field(default_factory=list)  # causes accepted whatever the judge says
    seed: int = 0
    workers: int = 1  # processes for simulation (does not change results)
    llm_timeout: float | None = None  # [s] per model request; None: REGEN_LLM_TIMEOUT, else 120
    pictures: bool = True  # GIFs and key frames (does not change verdicts)

    #: Fields whose change changes what a run produces: a resume must keep them.
    RESULT_FIELDS: ClassVar[tuple[str, ...]] = ("llm", "depth", "max_nodes", "max_scenarios", "causes",
                                      "max_entities", "prior", "candidates", "forced_causes", "seed")

    def limits(self) -> Limits:
        return Limits(max_depth=self.depth, max_nodes=self.max_nodes, max_causes=self.causes,
                      max_entities=self.max_entities)


class RunManifest(Model):
    """``run.json``."""

    behavior: Behavior
    settings: RunSettings
    domain_settings: dict[str, str | None] = Field(default_factory=dict)  # e.g. the resolved ego template
    status: str = "running"  # running, interrupted, failed, done
    started: str = ""
    finished: str | None = None
    timings: dict[str, float] = Field(default_factory=dict)  # stage -> wall seconds, over all invocations
    usage: dict[str, Any] = Field(default_factory=dict)  # model usage over every invocation of the run
    usage_last: dict[str, Any] = Field(default_factory=dict)  # model usage of the last invocation
    scenarios: list[str] = Field(default_factory=list)  # folder names, in run order
    message: str = ""


def merge_usage(a: dict[str, Any], b: dict[str, Any]) -> dict[str, Any]:
    """Sum two usage records (``regen.llm`` ``UsageStats.as_dict``) counter by counter."""

    def add(x: Any, y: Any) -> Any:
        if isinstance(x, dict) and isinstance(y, dict):
            return {k: add(x.get(k), y.get(k)) if k in x and k in y else (x.get(k) if k in x else y[k])
                    for k in {**x, **y}}
        if isinstance(x, (int, float)) and isinstance(y, (int, float)):
            return x + y
        return y if y is not None else x

    return add(a or {}, b or {})


def now() -> str:
    return dt.datetime.now(dt.timezone.utc).isoformat(timespec="seconds")


# --- defensive readers ---------------------------------------------------------------------------


@dataclass
class Loaded:
    """The outcome of reading one file: the value, or why there is none."""

    value: Any = None
    problem: str | None = None  # 'missing' or 'unreadable: ...'

    @property
    def ok(self) -> bool:
        return self.problem is None


def _short(exc: BaseException, limit: int = 200) -> str:
    msg = f"{type(exc).__name__}: {exc}"
    return msg if len(msg) <= limit else msg[:limit] + "..."


def read_json(path: Path) -> Loaded:
    """Parse a JSON file; a missing, oversized or broken file gives a problem, not an exception."""
    if not path.is_file():
        return Loaded(problem="missing")
    try:
        if path.stat().st_size > MAX_JSON_BYTES:
            return Loaded(problem=f"unreadable: larger than {MAX_JSON_BYTES // 1_000_000} MB")
        return Loaded(json.loads(path.read_text(encoding="utf-8")))
    except (OSError, UnicodeDecodeError, ValueError, RecursionError) as exc:
        return Loaded(problem=f"unreadable: {_short(exc)}")


def read_model(path: Path, model: type[M], key: str | None = None) -> Loaded:
    """Read a JSON file (or its ``key`` member) as a pydantic model."""
    raw = read_json(path)
    if not raw.ok:
        return raw
    data = raw.value
    if key is not None:
        if not isinstance(data, dict) or key not in data:
            return Loaded(problem=f"unreadable: no {key!r} member")
        data = data[key]
    try:
        return Loaded(model.model_validate(data))
    except ValidationError as exc:
        first = exc.errors()[0]
        where = ".".join(str(p) for p in first.get("loc", ()))
        return Loaded(problem=f"unreadable: {where or 'value'}: {first.get('msg', 'invalid')}"
                              f" ({exc.error_count()} error(s))")
    except Exception as exc:  # model validators may raise domain errors (e.g. GraphCycleError)
        return Loaded(problem=f"unreadable: {_short(exc)}")


def read_text(path: Path, limit: int = MAX_TEXT_CHARS) -> Loaded:
    """Read a text file, cut to ``limit`` characters (a note says how much was left out)."""
    if not path.is_file():
        return Loaded(problem="missing")
    try:
        text = path.read_text(encoding="utf-8", errors="replace")
    except OSError as exc:
        return Loaded(problem=f"unreadable: {_short(exc)}")
    if len(text) > limit:
        text = text[:limit] + f"\n[... {len(text) - limit} more characters in the file]"
    return Loaded(text)


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

    def __init__(self, path: Path):
        self.path = Path(path)
        self.name = self.path.name

    def __truediv__(self, name: str) -> Path:
        return self.path / name

    # readers
    def verdict(self) -> Verdict | None:
        """The verdict if the scenario finished (a broken verdict counts as unfinished)."""
        return read_model(self / self.VERDICT, Verdict).value

    def scenario(self) -> Scenario | None:
        return read_model(self / self.SCENARIO, Scenario, key="scenario").value

    def holds(self, path: CausePath) -> bool:
        """Whether the folder was made for ``path`` (a resume reuses nothing else)."""
        got = read_model(self / self.PATH, CausePath)
        return got.ok and got.value == path

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

    # writers (each atomic)
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
        """Record role -> file written by the domain (paths outside the folder are refused)."""
        known = self.files()
        for role, p in files.items():
            p = Path(p)
            if p.parent.resolve() != self.path.resolve():
                raise RunError(f"{p} is outside the scenario folder {self.path}; a domain writes "
                               "its files into the folder it is given")
            known[role] = p.name
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
        if not got.ok:
            raise RunError(f"{self / self.MANIFEST} is {got.problem}; run `regen generate` again with "
                           f"--out {self.path} --fresh to start over (the model cache is kept)")
        return got.value

    def write_manifest(self, manifest: RunManifest) -> None:
        write_json(self / self.MANIFEST, manifest)

    def is_run(self) -> bool:
        return (self / self.MANIFEST).is_file()

    # --- opening for writing -----------------------------------------------------------------

    def _check_writable(self) -> None:
        p = self.path
        if p.exists() and not p.is_dir():
            raise RunError(f"--out {p} is a file; give a folder (new or an earlier run's)")
        try:
            p.mkdir(parents=True, exist_ok=True)
        except (FileExistsError, NotADirectoryError):
            raise RunError(f"--out {p} lies under a file; give a folder path") from None
        except OSError as exc:
            raise RunError(f"cannot create the run folder {p}: {exc.strerror}; choose another --out") from None
        if not os.access(p, os.W_OK | os.X_OK):
            raise RunError(f"the run folder {p} is not writable; choose another --out")

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
        import fcntl

        fd = os.open(self / self.LOCK, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            other = os.read(fd, 64).decode("ascii", "replace").strip() or "?"
            os.close(fd)
            raise RunError(f"another regen process (pid {other}) is working on {self.path}; wait "
                           "for it to finish or choose another --out") from None
        os.ftruncate(fd, 0)
        os.write(fd, str(os.getpid()).encode())
        self._lock_fd = fd

    def unlock(self) -> None:
        if self._lock_fd is not None:
            os.close(self._lock_fd)  # closing releases the lock
            self._lock_fd = None

    def clear(self) -> None:
        """Remove the run's results for a fresh start; the model cache is kept (answers are
        keyed by model and prompt, so they stay valid)."""
        for name in (self.MANIFEST, self.GRAPH, "graph.png", "graph.html", self.EVENTS, self.SUMMARY,
                     self.REPORT):
            (self / name).unlink(missing_ok=True)
        shutil.rmtree(self / self.SCENARIOS, ignore_errors=True)

    def open(self, behavior: Behavior, settings: RunSettings, domain_settings: dict[str, str | None],
             *, fresh: bool = False) -> RunManifest:
        """Lock the folder and return the manifest to run under: a new one, or the stored one
        when this is a resume with the same behavior and result-changing settings."""
        self._check_writable()
        self.lock()
        try:
            if fresh:
                self.clear()
            if not self.is_run():
                return RunManifest(behavior=behavior, settings=settings,
                                   domain_settings=domain_settings, started=now())
            old, note = self._read_or_rebuild(behavior, settings, domain_settings)
            if (old.behavior.text, old.behavior.domain) != (behavior.text, behavior.domain):
                raise RunError(f"{self.path} holds a run of another behavior ('{old.behavior.text}', "
                               f"{old.behavior.domain}); use another --out folder, or --fresh to "
                               "replace it")
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
        except BaseException:
            self.unlock()
            raise


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


__all__ = ["Loaded", "RunFolder", "RunManifest", "RunSettings", "ScenarioFolder", "list_runs",
           "merge_usage", "now", "read_graph", "read_json", "read_model", "read_summary", "read_tests",
           "read_text"]
