"""Opening a user's file: one way for every command, and one line for every way it can fail.

A file a user names (a trajectory CSV, a labeled JSON-lines set, an OpenSCENARIO file and its
map, an asset database, a text set) is read here and nowhere else:

- a missing path, a folder, a file that cannot be read (no permission, a special file such as
  ``/proc/self/mem`` that answers with an I/O error) or one larger than the cap is a
  :class:`~regen.errors.ConfigError` that names the file and says what to give instead;
- text is UTF-8, with or without the byte-order mark a spreadsheet writes; anything else (a
  Latin-1 byte, a UTF-16 file) names the byte, its offset and its line and says to save the file
  as UTF-8;
- a JSON line, a CSV row (a field over the csv module's 128 KB limit included) or an XML
  element that cannot be parsed names the file and the line or row;
- a command's own JSON-lines results file that a kill cut off mid-line is resumed: the cut-off
  line is dropped (and said), a broken line before it is an error.

Every message is one line: ``<what> <path> <problem>: <what to do>``. Callers add their own
checks of the content with :func:`label`, so those name the file the same way.

Imports: :mod:`regen.errors` and the standard library only.
"""

from __future__ import annotations

import csv
import errno
import io
import json
import os
import xml.etree.ElementTree as ET
from collections.abc import Callable
from pathlib import Path
from typing import Any

from regen.errors import ConfigError, RegenError

MAX_BYTES = 50_000_000  # [bytes] a file a user gives is larger than this only by mistake
MAX_XML_DEPTH = 100  # [levels] OpenSCENARIO and OpenDRIVE nest about 20; deeper is not such a file
UTF8_BOM = b"\xef\xbb\xbf"
_UTF16_BOMS = (b"\xff\xfe", b"\xfe\xff")
_SHOWN = 120  # [characters] of a bad value quoted in a message


def label(path: str | Path, what: str = "") -> str:
    """How messages name a file: ``what`` (e.g. 'trajectory') and its path, quoted with escapes
    when it holds a line break or another character a terminal would obey."""
    shown_path = str(path) if str(path).isprintable() else repr(str(path))
    return f"{what} {shown_path}" if what else shown_path


def shown(value: str, limit: int = _SHOWN) -> str:
    """``value`` quoted for a one-line message: escapes for control characters, cut at ``limit``."""
    text = value if len(value) <= limit else value[:limit] + "..."
    return repr(text)


def read_bytes(path: str | Path, *, what: str = "", give: str, limit: int = MAX_BYTES) -> bytes:
    """The bytes of a user's file; ConfigError for a missing path, a folder, a file that cannot
    be read or one over ``limit`` [bytes]. ``give`` says what to give instead ('give a CSV file
    with a header t,x,y')."""
    p = Path(path)
    name = label(p, what)
    try:
        if p.is_dir():
            raise ConfigError(f"{name} is a folder: {give}")
        if not p.exists():
            raise ConfigError(f"{name} is not an existing file: {give}")
        if p.stat().st_size > limit:
            raise ConfigError(f"{name} is larger than {_mb(limit)}: {give}")
        with p.open("rb") as fh:
            data = fh.read(limit + 1)  # a special file's size says nothing (/dev/zero, a pipe)
    except OSError as exc:
        why = exc.strerror or type(exc).__name__
        todo = "check its permissions" if exc.errno in (errno.EACCES, errno.EPERM) else give
        raise ConfigError(f"{name} cannot be read ({why}): {todo}") from None
    except ValueError:  # a path holding a NUL character
        raise ConfigError(f"{name} is not a valid path: {give}") from None
    if len(data) > limit:
        raise ConfigError(f"{name} is larger than {_mb(limit)}: {give}")
    return data


def decode(data: bytes, name: str) -> str:
    """UTF-8 text of ``data`` without a byte-order mark; ConfigError naming the first bad byte,
    its offset and line (``name``: the file as :func:`label` gives it)."""
    if data.startswith(_UTF16_BOMS):
        raise ConfigError(f"{name} is UTF-16 text, not UTF-8: save it as UTF-8")
    skip = len(UTF8_BOM) if data.startswith(UTF8_BOM) else 0
    try:
        return data[skip:].decode("utf-8")
    except UnicodeDecodeError as exc:
        at = exc.start + skip
        line = data.count(b"\n", 0, at) + 1
        raise ConfigError(f"{name}, line {line}: not UTF-8 text (byte 0x{data[at]:02x} at offset {at}): "
                          "save it as UTF-8") from None


def read_text(path: str | Path, *, what: str = "", give: str, limit: int = MAX_BYTES) -> str:
    """The UTF-8 text of a user's file (a byte-order mark dropped); see :func:`read_bytes`."""
    return decode(read_bytes(path, what=what, give=give, limit=limit), label(path, what))


def _why(exc: ValueError) -> str:
    """What json.loads found wrong, without its position (the caller names the line)."""
    if isinstance(exc, json.JSONDecodeError):
        return f"{exc.msg} at column {exc.colno}"
    return str(exc).split(":")[0]  # e.g. an integer of more than 4300 digits


def parse_json(text: str, name: str, *, give: str, error: type[RegenError] = ConfigError) -> Any:
    """The JSON value of a whole file's ``text``; ``error`` (ConfigError unless the caller has a
    more precise one) naming the line and column, or the nesting."""
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise error(f"{name}: not valid JSON at line {exc.lineno}, column {exc.colno}: {exc.msg}; {give}") from None
    except ValueError as exc:
        raise error(f"{name}: not valid JSON ({_why(exc)}); {give}") from None
    except RecursionError:
        raise error(f"{name}: JSON nested too deeply; {give}") from None


def _line_value(line: str, where: str, give: str) -> Any:
    try:
        return json.loads(line)
    except ValueError as exc:
        raise ConfigError(f"{where}: not valid JSON ({_why(exc)}): {give}") from None
    except RecursionError:
        raise ConfigError(f"{where}: JSON nested too deeply: {give}") from None


def text_lines(text: str, name: str, *, give: str,
               skip: Callable[[str], bool] | None = None) -> list[tuple[int, Any]]:
    """(line number, value) of every non-blank line of JSON-lines ``text`` already read (``skip``:
    further lines to pass over, e.g. comments); ConfigError naming ``name`` and the line. Lines
    end at a newline only: a U+2028 inside a JSON string is text, not a line break."""
    out = []
    for n, line in enumerate(text.split("\n"), start=1):
        if line.strip() and not (skip is not None and skip(line)):
            out.append((n, _line_value(line, f"{name}, line {n}", give)))
    return out


def json_lines(path: str | Path, *, what: str = "", give: str, limit: int = MAX_BYTES,
               skip: Callable[[str], bool] | None = None) -> list[tuple[int, Any]]:
    """(line number, value) of every non-blank line of a user's JSON-lines file; see
    :func:`text_lines` and :func:`read_bytes`."""
    return text_lines(read_text(path, what=what, give=give, limit=limit), label(path, what), give=give, skip=skip)


def resume_json_lines(path: str | Path, *, what: str = "", give: str,
                      limit: int = MAX_BYTES) -> tuple[list[tuple[int, Any]], str | None]:
    """The rows of a command's own JSON-lines results file, to resume from: (line number, value)
    of each, and a note when a cut-off last line (a kill mid-write: no newline at its end, not
    valid JSON or not even UTF-8) was dropped. The file is cut back to its last whole line (or
    given the newline a whole last line lacks), so the next row appended starts a line of its
    own; a missing file has no rows. A broken line that is not the last is a ConfigError naming
    the file and the line."""
    p = Path(path)
    if not p.exists():
        return [], None
    name = label(p, what)
    data = read_bytes(p, what=what, give=give, limit=limit)
    end = data.rfind(b"\n") + 1  # 0: not one whole line
    tail = data[end:]
    note, repair = None, None
    if tail.strip():
        try:
            json.loads(tail.removeprefix(UTF8_BOM).decode("utf-8"))
            end, repair = len(data), b"\n"  # whole, only its newline missing
        except (ValueError, RecursionError):  # UnicodeDecodeError too: cut inside a character
            line = data.count(b"\n") + 1
            note = (f"{name}: dropped its cut-off last line {line} ({len(tail)} bytes, written when a run "
                    "was stopped); its case runs again")
            repair = b""
    rows = text_lines(decode(data[:end], name), name, give=give)
    if repair is not None:
        try:
            with p.open("r+b") as fh:  # cut back or finish the line; the rows before stay as written
                fh.truncate(end)
                fh.seek(0, os.SEEK_END)
                fh.write(repair)
        except OSError as exc:
            raise ConfigError(f"{name} cannot be repaired ({exc.strerror or exc}): check its permissions") from None
    return rows, note


def csv_rows(path: str | Path, *, what: str = "", give: str, limit: int = MAX_BYTES) -> list[tuple[int, list[str]]]:
    """(line number where the row starts, its fields) of every row of a CSV file, blank rows
    left out; ConfigError naming the file and the row for a row the csv module refuses (a field
    longer than its limit of 131072 characters)."""
    name = label(path, what)
    reader = csv.reader(io.StringIO(read_text(path, what=what, give=give, limit=limit), newline=""))
    out = []
    while True:
        start = reader.line_num + 1
        try:
            row = next(reader)
        except StopIteration:
            return out
        except csv.Error as exc:
            why = str(exc)
            if "field limit" in why:
                why = f"a field longer than {csv.field_size_limit()} characters"
            raise ConfigError(f"{name}: row {start}: {why}: {give}") from None
        if any(c.strip() for c in row):
            out.append((start, row))


def parse_xml(path: str | Path, *, what: str = "", give: str, limit: int = MAX_BYTES,
              element: Callable[..., ET.Element] | None = None) -> ET.Element:
    """The root element of a user's XML file; ConfigError naming the file and the line for XML
    that cannot be parsed, a document type that declares entities, or nesting deeper than
    :data:`MAX_XML_DEPTH`. ``element``: the element factory (a subclass that records reads).
    The parser expands no entity of its own and fetches nothing."""
    name = label(path, what)
    data = read_bytes(path, what=what, give=give, limit=limit)
    if b"<!ENTITY" in data:
        raise ConfigError(f"{name} declares XML entities (a <!DOCTYPE> with <!ENTITY>); they are not read: "
                          f"write the values out. {give[:1].upper()}{give[1:]}")
    parser = ET.XMLParser(target=ET.TreeBuilder(element_factory=element)) if element else ET.XMLParser()
    try:
        parser.feed(data)
        root = parser.close()
    except ET.ParseError as exc:
        line, col = exc.position
        why = str(exc).split(":")[0]
        raise ConfigError(f"{name} is not readable XML ({why} at line {line}, column {col + 1}): {give}") from None
    stack = [(root, 1)]
    while stack:
        el, depth = stack.pop()
        if depth > MAX_XML_DEPTH:
            raise ConfigError(f"{name} nests its elements more than {MAX_XML_DEPTH} deep: {give}")
        stack.extend((c, depth + 1) for c in el)
    return root


def _mb(n: int) -> str:
    return f"{n / 1_000_000:g} MB"


__all__ = ["MAX_BYTES", "MAX_XML_DEPTH", "csv_rows", "decode", "json_lines", "label", "parse_json", "parse_xml",
           "read_bytes", "read_text", "resume_json_lines", "shown", "text_lines"]
