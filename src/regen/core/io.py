"""Atomic file writes: a crash mid-write never leaves a half-written result behind; and how a
disk that takes no more (full, read-only) is told from other failures."""

from __future__ import annotations

import contextlib
import errno
import json
import os
import tempfile
from pathlib import Path
from typing import Any

from pydantic import BaseModel

from regen.errors import StorageError


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def atomic_write_bytes(path: str | os.PathLike[str], data: bytes) -> Path:
    """Write ``data`` to ``path`` via a temporary file in the same folder and a rename."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        # mkstemp makes the file owner-only; results are meant to be shared like any file
        os.fchmod(fd, 0o666 & ~_umask())
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        raise
    return path


def atomic_write_text(path: str | os.PathLike[str], text: str) -> Path:
    return atomic_write_bytes(path, text.encode("utf-8"))


def write_json(path: str | os.PathLike[str], value: BaseModel | Any) -> Path:
    """Write a pydantic model or plain JSON value atomically, pretty-printed."""
    if isinstance(value, BaseModel):
        text = value.model_dump_json(indent=2)
    else:
        text = json.dumps(value, indent=2, sort_keys=False, default=str)
    return atomic_write_text(path, text + "\n")


def try_lock(path: Path, *, shared: bool = False) -> tuple[int | None, str]:
    """An flock on ``path`` (created), without waiting: (open descriptor holding it, ''), or
    (None, the holder's pid as written in the file, '?' if none). An exclusive holder writes its
    pid; closing the descriptor releases the lock."""
    import fcntl

    fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        fcntl.flock(fd, (fcntl.LOCK_SH if shared else fcntl.LOCK_EX) | fcntl.LOCK_NB)
    except OSError:
        other = os.read(fd, 64).decode("ascii", "replace").strip() or "?"
        os.close(fd)
        return None, other
    if not shared:
        os.ftruncate(fd, 0)
        os.write(fd, str(os.getpid()).encode())
    return fd, ""


_FULL = (errno.ENOSPC, errno.EDQUOT)
_READ_ONLY = (errno.EROFS,)
_DENIED = (errno.EACCES, errno.EPERM)


def cannot_write(exc: BaseException, root: Path) -> bool:
    """Whether ``exc`` says that ``root`` cannot take more: a full disk or quota, a read-only
    file system, or a permission refused on a path inside ``root`` (elsewhere, e.g. a font
    cache, it is some other failure)."""
    if not isinstance(exc, OSError) or exc.errno is None:
        return False
    if exc.errno in _FULL + _READ_ONLY:
        return True
    if exc.errno in _DENIED and exc.filename:
        try:
            return Path(os.fsdecode(exc.filename)).resolve().is_relative_to(Path(root).resolve())
        except (OSError, TypeError, ValueError):
            return False
    return False


def storage_error(exc: OSError, root: Path) -> StorageError:
    """The one-line error for :func:`cannot_write`: what could not be written, why, what to do."""
    where = Path(os.fsdecode(exc.filename)) if exc.filename else Path(root)
    with contextlib.suppress(ValueError):
        where = Path(root) / where.resolve().relative_to(Path(root).resolve())
    fix = ("free some disk space" if exc.errno in _FULL
           else f"make {root} writable (or move the run to a writable place)")
    return StorageError(f"cannot write {where}: {exc.strerror or exc}; {fix}, then run the same "
                        "command again to resume")
