"""What Scenic's compiler made of text that never changes, kept on disk for the next process.

A fresh process (a ``regen generate``, a Ray worker, the batch pool's zygote) compiled before
its first scenario: the Newtonian driving world model and the three modules it imports
(translated to Python code), and the program's fixed helpers and behaviors (parsed statement by
statement). On a 2-core machine that took 1.5-2 s of the 2.4-3.2 s of a cold warm-up
(:mod:`regen.driving.simulation.warm`; issue 39, measured), and every Ray worker paid it again.
Both are functions of their text alone, so they are kept here once and read back:

- a module's translation (:mod:`~regen.driving.simulation.compile_cache`: its code object, the
  hash of its Python tree, its unparsed text), with :mod:`marshal` as Python writes ``.pyc``
  files; only imported modules without requirements, as the process's cache keeps them;
- the warm-up program's parsed statements (:mod:`~regen.driving.simulation.parse_cache`: the
  helpers and behaviors every program opens with), with :mod:`pickle` (Scenic's syntax nodes
  are rebuilt field by field, since their constructors want arguments); a process loads them
  before its first compilation (:func:`regen.driving.simulation.compile_cache.cached_compilation`),
  whether it warmed up or not.

A file is found by the SHA-256 of everything it depends on: a module's text and file name,
the Scenic version and Python's bytecode version; an upgraded Scenic or Python never
reads an old file. What is read is checked (its header, its types) and anything unreadable is
made afresh, so the cache can only save time, never change what runs. The files live in the
cache folder (``scenic-compiled/``, :func:`regen.paths.cache_dir`) beside the model files, at
most :data:`MAX_FILES` (the oldest out first). What is read here runs as the code it stands
for, as a ``.pyc`` does: the folder is the user's own, like every cache of the toolkit.
"""

from __future__ import annotations

import ast
import functools
import hashlib
import importlib.util
import io
import logging
import marshal
import os
import pickle
import tempfile
import types
from pathlib import Path
from typing import Any

log = logging.getLogger(__name__)

MAGIC = b"REGENSC1"  # this file layout; a new one when the kept objects change (parse_cache._Parsed)
MAX_FILES = 64  # files kept at most (the world model is 4 modules, the warm-up one program)
FOLDER = "scenic-compiled"


@functools.cache
def _scenic_version() -> bytes:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("scenic").encode()
    except PackageNotFoundError:  # Scenic run from a source tree: its translator's code stands in
        import scenic.syntax.translator as tr

        return hashlib.sha256(Path(tr.__file__).read_bytes()).hexdigest().encode()


def _path(kind: str, *texts: str) -> Path:
    """The file for ``texts`` of ``kind`` (its folder made here: OSError if it cannot be)."""
    from regen.paths import cache_dir

    h = hashlib.sha256()
    for part in (MAGIC, importlib.util.MAGIC_NUMBER, _scenic_version(), kind.encode(),
                 *(t.encode("utf-8") for t in texts)):
        h.update(len(part).to_bytes(8, "little"))
        h.update(part)
    return cache_dir(FOLDER) / f"{kind}-{h.hexdigest()[:40]}.bin"


def _read(kind: str, *texts: str) -> bytes | None:
    try:
        data = _path(kind, *texts).read_bytes()
    except OSError:
        return None
    return data[len(MAGIC):] if data.startswith(MAGIC) else None


def _write(payload: bytes, kind: str, *texts: str) -> None:
    """``payload`` into its file atomically, then the oldest files out; failures only logged."""
    try:
        path = _path(kind, *texts)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".tmp-", suffix=".bin")
        try:
            with os.fdopen(fd, "wb") as fh:
                fh.write(MAGIC + payload)
            os.replace(tmp, path)
        except BaseException:
            Path(tmp).unlink(missing_ok=True)
            raise
        files = sorted(path.parent.glob("*.bin"), key=lambda p: p.stat().st_mtime)
        for old in files[:max(0, len(files) - MAX_FILES)]:
            old.unlink(missing_ok=True)
    except OSError as exc:  # a read-only or full disk: the process's own caches still work
        log.debug("a Scenic %s not kept on disk: %s", kind, exc)


def read_translation(filename: str, source: str) -> tuple[types.CodeType, bytes, str] | None:
    """The kept translation of the module ``filename`` with text ``source``: (code, tree hash,
    unparsed text); None if there is none or it cannot be read."""
    data = _read("module", filename, source)
    if data is None:
        return None
    try:
        code, ast_hash, python_source = marshal.loads(data)
    except (ValueError, EOFError, TypeError) as exc:
        log.debug("unreadable Scenic translation of %s (%s): translating again", filename, exc)
        return None
    if not (isinstance(code, types.CodeType) and isinstance(ast_hash, bytes) and isinstance(python_source, str)
            and code.co_filename == filename):
        return None
    return code, ast_hash, python_source


def write_translation(filename: str, source: str, code: types.CodeType, ast_hash: bytes,
                      python_source: str) -> None:
    """Keep a module's translation for later processes."""
    try:
        payload = marshal.dumps((code, ast_hash, python_source))
    except ValueError as exc:  # a constant marshal cannot write
        log.debug("translation of %s not kept on disk: %s", filename, exc)
        return
    _write(payload, "module", filename, source)


def _rebuild(cls: type, fields: dict[str, Any]) -> ast.AST:
    node = cls.__new__(cls)
    node.__dict__.update(fields)
    return node


class _Pickler(pickle.Pickler):
    def reducer_override(self, obj: Any) -> Any:
        if isinstance(obj, ast.AST) and type(obj).__module__ != "ast":  # Scenic's own nodes
            return _rebuild, (type(obj), obj.__dict__)
        return NotImplemented


def read_parses() -> list[Any] | None:
    """The parse-cache entries kept by :func:`write_parses`; None if none can be read."""
    from regen.driving.simulation.parse_cache import are_entries

    data = _read("parses")
    if data is None:
        return None
    try:
        entries = pickle.loads(data)  # noqa: S301 (the user's own cache folder, as for a .pyc)
    except Exception as exc:  # noqa: BLE001 (an unreadable cache file is only a miss)
        log.debug("unreadable kept parses (%s): parsing again", exc)
        return None
    return entries if are_entries(entries) else None


def write_parses(entries: list[Any]) -> None:
    """Keep parse-cache entries (:func:`regen.driving.simulation.parse_cache.recording`: the
    warm-up program's) for later processes. An entry is keyed by its statement's text, so one
    that no program has again is never used: one file serves every program."""
    buf = io.BytesIO()
    try:
        _Pickler(buf, protocol=pickle.HIGHEST_PROTOCOL).dump(entries)
    except (pickle.PicklingError, TypeError, AttributeError) as exc:
        log.debug("parses not kept on disk: %s", exc)
        return
    _write(buf.getvalue(), "parses")


__all__ = ["MAX_FILES", "read_parses", "read_translation", "write_parses", "write_translation"]
