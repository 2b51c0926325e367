"""``RUN/scenarios/<name>/``: one cause chain's folder (:class:`ScenarioFolder`), its files by
name, their readers and their atomic writers; what the run wrote there is recorded in
``written.json`` so that ``--fresh`` removes only that (:mod:`regen.runfolder.fresh`)."""

from __future__ import annotations

import contextlib
import hashlib
from collections.abc import Collection, Iterator
from pathlib import Path
from typing import ClassVar

from regen.core.graph import CausePath
from regen.core.io import atomic_write_text, write_json
from regen.core.scenario import Scenario
from regen.core.trace import Trace
from regen.core.verdict import Verdict
from regen.errors import RunError
from regen.promises.folders import entries, is_temp_of
from regen.runfolder.readers import read_json, read_model


class ScenarioFolder:
    """``RUN/scenarios/<name>/``: one cause chain's files."""

    PATH = "path.json"
    SCENARIO = "scenario.json"
    #: the scenario as grounded, kept when the verdict's relaxed FSM replaced it in scenario.json:
    #: an attempt that ends before its verdict (a killed worker, a killed run) starts again from
    #: it, never from a relaxed FSM that would then verify with no relaxation said
    GROUNDED = "scenario.grounded.json"
    TRACE = "trace.json"
    VERDICT = "verdict.json"
    TIMINGS = "timings.json"
    FILES = "files.json"
    ERROR = "error.txt"
    #: the names of what the domain's steps (simulate, render, export) wrote here, beside the
    #: folder's own files: what ``--fresh`` may remove (:mod:`.fresh`)
    WRITTEN = "written.json"
    #: the files every scenario folder may hold, by name
    OWN: ClassVar[tuple[str, ...]] = (PATH, SCENARIO, GROUNDED, TRACE, VERDICT, TIMINGS, FILES, ERROR, WRITTEN)

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

    def write_relaxed(self, scenario: Scenario, config: dict) -> None:
        """scenario.json becomes the relaxed scenario the verdict is about; the grounded one is
        kept first as :attr:`GROUNDED` (once: it is always the one grounding wrote)."""
        if not (self / self.GROUNDED).is_file():
            atomic_write_text(self / self.GROUNDED, (self / self.SCENARIO).read_text(encoding="utf-8"))
        self.write_scenario(scenario, config)

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
            names += [self.PATH, self.SCENARIO, self.GROUNDED, self.TIMINGS]
        elif (self / self.GROUNDED).is_file():  # an attempt relaxed the FSM: back to the grounded one
            (self / self.GROUNDED).replace(self / self.SCENARIO)
        for name in names:
            (self / name).unlink(missing_ok=True)


__all__ = ["ScenarioFolder"]
