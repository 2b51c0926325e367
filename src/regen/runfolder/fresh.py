"""What ``regen generate --fresh`` may remove: the files of a run, and nothing else.

A run writes a fixed set of top-level files (``RunFolder.RUN_FILES``) and one folder per cause
chain under ``scenarios/`` (everything in such a folder is the run's: the domain writes its
pictures and exports into the folder it is given). Anything else in the folder (a user's
``notes.txt``, a ``scenarios/mywork/`` subfolder, another tool's ``run.json``) is not the run's:
``--fresh`` then removes nothing and names what it found, so that the user moves it or chooses
another folder. The model cache, the lock and ``tests/`` (``regen test``'s results) are kept.
"""

from __future__ import annotations

from collections.abc import Collection
from pathlib import Path
from typing import TYPE_CHECKING

from regen.core.graph import CausePath, ScenarioGraph
from regen.errors import RunError
from regen.runfolder.manifest import RunManifest
from regen.runfolder.readers import read_model

if TYPE_CHECKING:
    from regen.runfolder import RunFolder


def _is_temp_of(name: str, names: Collection[str]) -> bool:
    """Whether ``name`` is a temporary file of an atomic write of one of ``names``
    (``regen.core.io``: ``.<name>.<random>.tmp``), left by a crash."""
    return name.startswith(".") and name.endswith(".tmp") and any(name.startswith(f".{n}.") for n in names)


def _made_by_run(run: RunFolder, folder: Path, listed: Collection[str]) -> bool:
    """Whether ``scenarios/<folder>`` is a scenario folder a run made: listed in run.json, holding
    a cause path (the first file a run writes there), or empty."""
    sf = run.scenario(folder.name)
    if folder.name in listed or read_model(sf / sf.PATH, CausePath).ok:
        return True
    try:
        return not any(folder.iterdir())
    except OSError:
        return False


def _listing(names: list[str]) -> str:
    return ", ".join(names[:6]) + (f" and {len(names) - 6} more" if len(names) > 6 else "")


def _entries(path: Path) -> list[Path]:
    try:
        return sorted(path.iterdir())
    except OSError as exc:
        raise RunError(f"cannot list {path} ({exc.strerror}); choose another --out") from None


def fresh_plan(run: RunFolder) -> list[Path]:
    """The paths ``--fresh`` removes (``scenarios/`` last, to be removed once empty). RunError,
    naming what was found, when the folder holds anything a run does not write, or anything at
    all while it is not recognisably a run (neither run.json nor graph.json reads as one)."""
    if not run.path.is_dir():
        return []
    manifest = read_model(run / run.MANIFEST, RunManifest)
    listed = set(manifest.value.scenarios) if manifest.ok else set()
    remove: list[Path] = []
    foreign: list[str] = []  # what a run does not write
    found: list[str] = []  # everything but the kept entries, as named in a message
    for p in _entries(run.path):
        if p.name in run.KEPT:
            continue
        if p.name == run.SCENARIOS and p.is_dir() and not p.is_symlink():
            for q in _entries(p):
                shown = f"{run.SCENARIOS}/{q.name}{'/' if q.is_dir() else ''}"
                found.append(shown)
                if q.is_dir() and not q.is_symlink() and _made_by_run(run, q, listed):
                    remove.append(q)
                else:
                    foreign.append(shown)
            remove.append(p)
            continue
        found.append(p.name + ("/" if p.is_dir() else ""))
        if (p.name in run.RUN_FILES or _is_temp_of(p.name, run.RUN_FILES)) and (p.is_file() or p.is_symlink()):
            remove.append(p)
        else:
            foreign.append(found[-1])
    if found and not (manifest.ok or read_model(run / run.GRAPH, ScenarioGraph).ok):
        why = "no run.json" if manifest.problem == "missing" else f"its run.json is {manifest.problem}"
        raise RunError(f"--fresh: {run.path} is not a regen run ({why}); it holds {_listing(found)}; "
                       "nothing was removed: move the folder aside or choose another --out")
    if foreign:
        raise RunError(f"--fresh: {run.path} holds what a run does not write ({_listing(foreign)}); "
                       "nothing was removed: move those out of the folder, or choose another --out")
    return remove


__all__ = ["fresh_plan"]
