"""Naming things on disk from user or model text: a name is one plain entry of the folder it is
given, never a path out of it.

Two ways, chosen by whoever names:

- :func:`safe_name` refuses (a one-line :class:`~regen.errors.ConfigError` saying why and what
  to give) any text that is not already a safe name. For text a user chose and can change, where
  two names must stay two folders: a case id of ``regen eval --fidelity``, say. Slugging it
  would hide the mistake and could merge ``a/b`` and ``a_b`` into one folder.
- :func:`slug` turns any text into a safe name (lower-case letters and digits joined by ``-``),
  never empty. For text nobody can be asked to change: a model's cause text, a file's stem. The
  caller makes such names unique where it matters (a scenario folder's ``01-`` prefix).

A safe name has no separator (``/`` or ``\\``), so it is no absolute path and no path into
another folder; it is not ``.`` or ``..`` and does not start with a dot (a hidden entry beside
the toolkit's own lock and temporary files); it holds no control, line-break, bidi or other
invisible character and no lone surrogate; it does not start or end with whitespace; and it is
at most :data:`MAX_NAME_CHARS` characters (and 255 bytes, what file systems take).
"""

from __future__ import annotations

import re
from pathlib import Path

from regen.errors import ConfigError
from regen.promises.terminal import NOT_PRINTABLE, printable

MAX_NAME_CHARS = 100  # longest name made from text [characters]
MAX_NAME_BYTES = 255  # what ext4, APFS and NTFS take for one entry [bytes of UTF-8]
_SEPARATORS = ("/", "\\")
_SLUG_DROP = re.compile(r"[^a-z0-9]+")
_QUOTED_CHARS = 60  # how much of a refused text a message quotes


def problem(text: str) -> str | None:
    """Why ``text`` cannot name an entry of a folder as it is ('holds a path separator', ...),
    or None when it can."""
    if not text.strip():
        return "is empty"
    if text in (".", ".."):
        return "names a folder itself, not an entry of it"
    if text.startswith(("/", "\\")) or re.match(r"[A-Za-z]:[\\/]", text):
        return "is an absolute path"
    if any(s in text for s in _SEPARATORS):
        return "holds a path separator (/ or \\)"
    if NOT_PRINTABLE.search(text):
        return "holds a control, line-break or invisible character"
    if text.startswith("."):
        return "starts with a dot (a hidden name)"
    if text != text.strip():
        return "starts or ends with a space"
    if len(text) > MAX_NAME_CHARS or len(text.encode("utf-8", "surrogatepass")) > MAX_NAME_BYTES:
        return f"is longer than {MAX_NAME_CHARS} characters"
    return None


def _quoted(text: str) -> str:
    shown = printable(text)
    return shown if len(shown) <= _QUOTED_CHARS else shown[:_QUOTED_CHARS - 1] + "\u2026"


def safe_name(text: str, *, what: str = "a name") -> str:
    """``text`` itself when it is a safe name (see the module docstring); ConfigError otherwise,
    on one line: '``what`` '../x' cannot name a folder: it holds a path separator (/ or \\);
    give a plain name ...'."""
    why = problem(text)
    if why is None:
        return text
    raise ConfigError(f"{what} '{_quoted(text)}' cannot name a folder: it {why}; give a plain name "
                      f"(letters, digits, '-', '_', '.'; at most {MAX_NAME_CHARS} characters)")


def child(base: Path, text: str, *, what: str = "a name") -> Path:
    """``base / text`` for a :func:`safe_name` ``text`` (ConfigError otherwise): an entry of
    ``base``, never a path out of it."""
    return Path(base) / safe_name(text, what=what)


def slug(text: str, *, limit: int = 40, fallback: str = "item") -> str:
    """``text`` as a safe name: lower-case ASCII letters and digits, every other run of
    characters one ``-``, at most ``limit`` characters, never empty (``fallback``, itself a
    slug, when nothing is left)."""
    s = _SLUG_DROP.sub("-", text.lower()).strip("-")
    return s[:max(1, min(limit, MAX_NAME_CHARS))].rstrip("-") or fallback


__all__ = ["MAX_NAME_BYTES", "MAX_NAME_CHARS", "child", "problem", "safe_name", "slug"]
