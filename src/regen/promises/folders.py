"""Choosing an output folder: every command that writes says, on one line and before it writes
anything, what is wrong with the folder it was given and what to give instead.

- :func:`out_folder`: the folder an option names (an empty value is refused: ``Path("")`` is the
  current folder, which would receive a whole run unasked).
- :func:`output_folder`: the folder made and writable, or a one-line error for a file in its
  place, a file on its path, a folder that cannot be made or written.
- :func:`beside_run`: the default output folder of a command that works on one scenario folder
  of a run (``RUN/whatif``): only when the scenario folder is inside a run; anywhere else the
  command would write into whatever folder lies two levels up, so it asks for ``--out``.
- :func:`foreign_error`: the refusal of a folder that holds what the command did not write (the
  command removes nothing then); :func:`entries`, :func:`is_temp_of` and :func:`listing` help a
  command tell its own files from others.

Messages end with what to do. The error type is the caller's (a run folder's problems are
:class:`~regen.errors.RunError`, an option's :class:`~regen.errors.ConfigError`); both exit 2.
"""

from __future__ import annotations

import os
from collections.abc import Collection
from pathlib import Path

from regen.errors import ConfigError, RegenError

_LISTED = 6  # entries a message names before 'and N more'


def out_folder(value: str | os.PathLike[str], option: str = "--out") -> Path:
    """The folder a command's ``option`` names; ConfigError for an empty value (``Path("")`` is
    the current folder, which would receive a whole run unasked)."""
    if not str(value).strip():
        raise ConfigError(f"{option} is empty: give a folder path, e.g. {option} runs/my-run")
    return Path(value)


def make_folder(path: Path) -> str | None:
    """Create ``path`` (and its parents) as a writable folder. None, or what is wrong: 'file' (it
    is one), 'under_file' (a parent is one), 'not_writable', or the OS's reason it cannot be made."""
    path = Path(path)
    if path.exists() and not path.is_dir():
        return "file"
    try:
        path.mkdir(parents=True, exist_ok=True)
    except (FileExistsError, NotADirectoryError):
        return "under_file"
    except OSError as exc:
        return str(exc.strerror or exc)
    return None if os.access(path, os.W_OK | os.X_OK) else "not_writable"


def output_folder(path: str | os.PathLike[str], *, option: str = "--out", given: bool = True,
                  give: str = "a folder", what: str = "", error: type[RegenError] = ConfigError) -> Path:
    """``path`` made (with its parents) and writable; ``error`` on one line otherwise.

    ``given``: the user named the folder with ``option`` (else it is the command's default
    place, and the message says to give ``option``); ``give``: what to give instead of a file
    ('a folder for tests.json and junit.xml'); ``what``: how the message names the folder ('the
    run folder')."""
    p = Path(path)
    problem = make_folder(p)
    if problem is None:
        return p
    named = f"{option} {p}" if given else (f"{what} {p}" if what else str(p))
    label = f"{what} {p}" if what else str(p)
    instead = f"give {give}" if given else f"move it aside or give {option} FOLDER"
    raise error({"file": f"{named} is a file; {instead}",
                 "under_file": f"{named} lies under a file; "
                               + ("give a folder path" if given else f"give {option} FOLDER"),
                 "not_writable": f"{label} is not writable; choose another {option}"}
                .get(problem, f"cannot create {label}: {problem}; choose another {option}"))


def run_of(folder: str | os.PathLike[str], *, manifest: str, scenarios: str) -> Path | None:
    """The run a scenario folder belongs to: ``RUN`` when ``folder`` is ``RUN/<scenarios>/<name>``
    and ``RUN/<manifest>`` is a file; else None."""
    p = Path(os.path.abspath(folder))  # lexically: 'RUN/scenarios/x/..' is not a scenario folder
    run = p.parent.parent
    return run if p.parent.name == scenarios and (run / manifest).is_file() else None


def beside_run(folder: str | os.PathLike[str], sub: str, *, manifest: str, scenarios: str,
               option: str = "--out", writes: str = "its results") -> Path:
    """``RUN/<sub>``, the default output folder of a command given the scenario folder
    ``RUN/<scenarios>/<name>`` of a run (:func:`run_of`); ConfigError, saying what to give, when
    ``folder`` is not inside a run (the folder two levels up is then anybody's)."""
    run = run_of(folder, manifest=manifest, scenarios=scenarios)
    if run is None:
        raise ConfigError(f"{folder} is not a scenario folder of a run (RUN/{scenarios}/<name> beside "
                          f"RUN/{manifest}), so there is no run to write {writes} into; give a scenario "
                          f"folder of a run, or say where to write with {option} FOLDER")
    return run / sub


def entries(path: Path, *, option: str = "--out", error: type[RegenError] = ConfigError) -> list[Path]:
    """The entries of the folder ``path``, sorted; ``error`` naming the OS's reason when it
    cannot be listed."""
    try:
        return sorted(Path(path).iterdir())
    except OSError as exc:
        raise error(f"cannot list {path} ({exc.strerror or exc}); choose another {option}") from None


def is_temp_of(name: str, names: Collection[str]) -> bool:
    """Whether ``name`` is a temporary file of an atomic write of one of ``names``
    (``regen.core.io``: ``.<name>.<random>.tmp``), left by a crash."""
    return name.startswith(".") and name.endswith(".tmp") and any(name.startswith(f".{n}.") for n in names)


def listing(names: list[str]) -> str:
    """``names`` for a message: the first few, then how many more."""
    more = len(names) - _LISTED
    return ", ".join(names[:_LISTED]) + (f" and {more} more" if more > 0 else "")


def foreign_error(folder: Path, foreign: list[str], *, doing: str, writer: str, option: str = "--out",
                  error: type[RegenError] = ConfigError) -> RegenError:
    """The refusal of ``folder`` because it holds ``foreign`` entries (named relative to it),
    which ``writer`` ('a run') does not write: nothing was removed, and what to do."""
    return error(f"{doing}: {folder} holds what {writer} does not write ({listing(foreign)}); nothing was "
                 f"removed: move those out of the folder, or choose another {option}")


__all__ = ["beside_run", "entries", "foreign_error", "is_temp_of", "listing", "make_folder", "out_folder",
           "output_folder", "run_of"]
