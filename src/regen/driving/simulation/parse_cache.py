"""Scenic's parsing, cached per top-level statement for the life of the process.

Where compiling goes (profiled, issue 39): compiling a scenario's program takes 1-2 s, and 95%
of it is Scenic's parser (a PEG parser in pure Python). About 0.6 s re-parses the Newtonian
driving world model and the modules it imports, which Scenic compiles afresh for every program
(it drops them after each compilation, since they read the ``map`` parameter when they run);
0.25 s parses the program's helper functions and behaviors, the same text in every program; 0.1 s
its actor statements. Running the parsed program (the objects, the road network from the map's
``.snet`` cache) takes 0.03-0.06 s.

Scenic cannot run a compiled scenario again with other numbers: a program's objects, and the
arguments of their behaviors, are made when its module runs, at compile time, and global
parameters are bound then. So the parse is what is reused: a source is split at its top-level
statements (by Python's tokenizer, the one Scenic's parser reads), and each statement is parsed
once per process with every number literal replaced by a placeholder name; a statement that
differs only in its numbers (an actor placed elsewhere, a variant's speeds) reuses that parse,
its numbers put back as the constants the parser makes and the columns after them moved to where
they are. The module built from the statements is the AST Scenic's parser gives for the whole
text (tests/driving/simulation/test_parse_cache.py), so compiling and running it does what the
uncached compilation does. Where a number does not come back as a plain name (a ``case``
pattern, a ``require [p]`` probability), the statement is parsed as it is; where anything else
fails, the whole source is parsed by Scenic, which reports its own errors.

The cache is per process and bounded (:data:`MAX_CHARS` of statement text, least recently used
first out); parsed statements are handed out as copies, since Scenic's compiler rewrites the
tree it is given.
"""

from __future__ import annotations

import ast
import bisect
import contextlib
import functools
import io
import tokenize
from collections import OrderedDict
from collections.abc import Iterator
from dataclasses import dataclass

MAX_CHARS = 1_000_000  # statement text the cache holds at most [characters] (~37 bytes of tree each: ~40 MB)
_CLAUSES = frozenset({"else", "elif", "except", "finally", "interrupt"})  # continue the statement above
PLACEHOLDER = "_"  # what a number literal becomes in a statement's key


@dataclass
class _Statement:
    """One top-level statement of a source: its lines (1-based, inclusive) and numbers."""

    first: int
    last: int
    numbers: list[tuple[int, int, str]]  # (row, column, text), row relative to ``first`` (1-based)


@dataclass
class _Parsed:
    body: list[ast.stmt]  # as parsed from the key's text, rows relative to the statement
    places: frozenset[tuple[int, int]] | None = None  # (row, column) where a placeholder parsed
    # as a name that is read: a number there parses as a constant; None: a statement's own text


_cache: OrderedDict[tuple[str, str], _Parsed] = OrderedDict()
_cached_chars = 0
stats = {"hits": 0, "misses": 0, "as_written": 0}  # statements served, for tests and benchmarks


def split(source: str) -> list[_Statement]:
    """The top-level statements of ``source`` (a compound statement with its clauses, a
    decorated one with its decorators), each with the number literals it holds."""
    out: list[_Statement] = []
    depth, start, end, new_line, decorated = 0, 0, 0, True, False
    numbers: list[tuple[int, int, str]] = []
    for tok in tokenize.generate_tokens(io.StringIO(source).readline):
        kind = tok.type
        if kind == tokenize.INDENT:
            depth += 1
        elif kind == tokenize.DEDENT:
            depth -= 1
        elif kind == tokenize.NEWLINE:
            end, new_line = tok.start[0], True
        elif kind in (tokenize.NL, tokenize.COMMENT, tokenize.ENDMARKER):
            continue
        elif new_line:
            new_line = False
            if depth == 0 and not decorated and not (kind == tokenize.NAME and tok.string in _CLAUSES):
                if start:
                    out.append(_Statement(start, end, numbers))
                start, numbers = tok.start[0], []
            if depth == 0:
                decorated = tok.string == "@"
        if kind == tokenize.NUMBER:
            numbers.append((tok.start[0] - start + 1, tok.start[1], tok.string))
    if start:
        out.append(_Statement(start, end, numbers))
    return out


@functools.lru_cache(maxsize=64)
def _split_cached(source: str) -> tuple[_Statement, ...]:
    """:func:`split`, once per source text: the world model's modules are the same text at every
    compilation (tokenizing them again took a tenth of a warm one)."""
    return tuple(split(source))


def _key_positions(numbers: list[tuple[int, int, str]]) -> list[tuple[int, int]]:
    """Where each number's placeholder sits in the key: columns move left by the lengths of
    the numbers before it on its row, less the placeholder's."""
    out, row_seen, shift = [], None, 0
    for row, col, num in numbers:
        if row != row_seen:
            row_seen, shift = row, 0
        out.append((row, col - shift))
        shift += len(num) - len(PLACEHOLDER)
    return out


def _key(text: str, numbers: list[tuple[int, int, str]]) -> str:
    """``text`` with every number literal replaced by :data:`PLACEHOLDER`."""
    lines = text.split("\n")
    for row, col, num in reversed(numbers):  # right to left: earlier columns stay valid
        line = lines[row - 1]
        lines[row - 1] = line[:col] + PLACEHOLDER + line[col + len(num):]
    return "\n".join(lines)


def _read_names(body: list[ast.stmt]) -> frozenset[tuple[int, int]]:
    """Where a placeholder parsed as a plain name that is read (not a pattern, not a target)."""
    return frozenset((n.lineno, n.col_offset) for stmt in body for n in ast.walk(stmt)
                     if isinstance(n, ast.Name) and n.id == PLACEHOLDER and isinstance(n.ctx, ast.Load)
                     and n.end_lineno == n.lineno and n.end_col_offset == n.col_offset + len(PLACEHOLDER))


def _lookup(key: tuple[str, str]) -> _Parsed | None:
    parsed = _cache.get(key)
    if parsed is not None:
        _cache.move_to_end(key)
    return parsed


def _store(key: tuple[str, str], parsed: _Parsed) -> None:
    global _cached_chars
    _cache[key] = parsed
    _cached_chars += len(key[1])
    while _cached_chars > MAX_CHARS and len(_cache) > 1:
        old, _ = _cache.popitem(last=False)
        _cached_chars -= len(old[1])


def _statement(text: str, stmt: _Statement, parse) -> list[ast.stmt]:
    """The statement ``text`` parsed, rows and columns where ``stmt`` has them, from the cache
    when its key (numbers as placeholders) or its own text is there."""
    if stmt.numbers:
        key, places = ("key", _key(text, stmt.numbers)), _key_positions(stmt.numbers)
        parsed = _lookup(key)
        if parsed is None:
            stats["misses"] += 1
            try:
                body = parse(key[1], "exec").body
                parsed = _Parsed(body, _read_names(body))
            except Exception:  # a placeholder where only a number parses (require [p]: ...)
                parsed = _Parsed([], frozenset())
            _store(key, parsed)
        else:
            stats["hits"] += 1
        if parsed.places is not None and parsed.places.issuperset(places):
            return _Copy(stmt.first - 1, stmt.numbers).many(parsed.body)
        stats["as_written"] += 1  # a number where a name parses otherwise (case 1:)
    key = ("text", text)
    parsed = _lookup(key)
    if parsed is None:
        stats["misses"] += 1
        parsed = _Parsed(parse(text, "exec").body)
        _store(key, parsed)
    else:
        stats["hits"] += 1
    return _Copy(stmt.first - 1).many(parsed.body)


class _Copy:
    """Copies of a cached tree, ``rows`` rows further down, a statement's numbers put back."""

    def __init__(self, rows: int, numbers: list[tuple[int, int, str]] = ()):
        self.rows = rows
        self.constants: dict[tuple[int, int], tuple[str, int]] = {}
        self.moves: dict[int, tuple[list[int], list[int]]] = {}  # row -> (key columns, shifts)
        for (row, kcol), (_, col, num) in zip(_key_positions(numbers), numbers, strict=True):
            self.constants[(row, kcol)] = (num, col)
            cols, shifts = self.moves.setdefault(row, ([], []))
            cols.append(kcol + len(PLACEHOLDER))  # columns from here on move right
            shifts.append(col + len(num) - cols[-1])

    def column(self, row: int, col: int) -> int:
        """Where column ``col`` of the key's row ``row`` is in the statement."""
        moved = self.moves.get(row)
        if moved is None:
            return col
        i = bisect.bisect_right(moved[0], col)
        return col + moved[1][i - 1] if i else col

    def many(self, body: list[ast.stmt]) -> list[ast.stmt]:
        return [self.node(s) for s in body]

    def node(self, node):
        if isinstance(node, list):
            return [self.node(x) for x in node]
        if isinstance(node, tuple):
            return tuple(self.node(x) for x in node)
        if not isinstance(node, ast.AST):
            return node
        if self.constants and isinstance(node, ast.Name) and node.id == PLACEHOLDER:
            hit = self.constants.get((node.lineno, node.col_offset))
            if hit is not None:  # as Scenic's grammar makes a number atom
                num, col = hit
                return ast.Constant(value=ast.literal_eval(num), lineno=node.lineno + self.rows,
                                    col_offset=col, end_lineno=node.end_lineno + self.rows,
                                    end_col_offset=col + len(num))
        cls = node.__class__
        new = cls.__new__(cls)
        fields = new.__dict__
        for k, v in node.__dict__.items():
            fields[k] = self.node(v) if isinstance(v, (ast.AST, list, tuple)) else v
        if "lineno" in cls._attributes:
            for row_attr, col_attr in (("lineno", "col_offset"), ("end_lineno", "end_col_offset")):
                row = fields.get(row_attr)
                if row is None:
                    continue
                if self.moves and fields.get(col_attr) is not None:
                    fields[col_attr] = self.column(row, fields[col_attr])
                fields[row_attr] = row + self.rows
        return new


def parse_module(source: str, parse) -> ast.Module:
    """``source`` parsed as ``parse(text, "exec")`` (Scenic's parser) parses it, one cached
    top-level statement at a time."""
    if "\r" in source or "\f" in source:  # line ends the statement split does not count as Scenic does
        return parse(source, "exec")
    lines = source.split("\n")
    body: list[ast.stmt] = []
    for stmt in _split_cached(source):
        text = "\n".join(lines[stmt.first - 1:stmt.last]) + "\n"
        body.extend(_statement(text, stmt, parse))
    return ast.Module(body=body, type_ignores=[])


@contextlib.contextmanager
def cached_parsing() -> Iterator[None]:
    """Within this block, Scenic compiles (``scenarioFromString`` and the world models it
    imports) through the statement cache. Scenic calls its parser by a module-level name, which
    is the only place to step in; the name is restored on the way out."""
    from scenic.syntax import translator

    original = translator.parse_string
    if getattr(original, "_regen_cached", False):  # nested: the outer block serves
        yield
        return

    def parse_string(source, mode, *args, filename="<unknown>", **kwargs):
        if mode != "exec" or args or kwargs:
            return original(source, mode, *args, filename=filename, **kwargs)
        try:
            return parse_module(source, lambda text, m: original(text, m, filename=filename))
        except Exception:  # a syntax error, or a source the statement split misreads
            return original(source, mode, filename=filename)

    parse_string._regen_cached = True
    translator.parse_string = parse_string
    try:
        yield
    finally:
        translator.parse_string = original


def clear() -> None:
    """Empty the cache (tests)."""
    global _cached_chars
    _cache.clear()
    _split_cached.cache_clear()
    _cached_chars = 0
    for k in stats:
        stats[k] = 0


__all__ = ["MAX_CHARS", "cached_parsing", "clear", "parse_module", "split", "stats"]
