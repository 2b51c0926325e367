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
once per process with every number literal (a sign glued to it where only a sign can stand:
``(-1.75``) and every one-line ASCII string literal (an actor's name) replaced by a placeholder
name; a statement that differs only in these (an actor placed elsewhere, another actor of the
same kind, a variant's speeds) reuses that parse,
its numbers put back as the constants the parser makes and the columns after them moved to where
they are. The module built from the statements is the AST Scenic's parser gives for the whole
text (tests/driving/simulation/test_parse_cache.py), so compiling and running it does what the
uncached compilation does. A list display of runs of like tuples of numbers (a route's points, a
speed schedule) is keyed with each run written once: a route of 80 points and one of 60 share a
parse (:func:`_collapse`), the run's tuple copied as many times as the statement has it. Where a
number does not come back as a plain name (a ``case``
pattern, a ``require [p]`` probability), the statement is parsed as it is; where anything else
fails, the whole source is parsed by Scenic, which reports its own errors.

The cache is per process and bounded (:data:`MAX_CHARS` of statement text, least recently used
first out); parsed statements are handed out as copies, since Scenic's compiler rewrites the
tree it is given. :data:`LOCK` guards the cache and the swapped parser: a thread's block runs
alone (Scenic's compiler keeps its state in module globals, so compilations must not overlap).
"""

from __future__ import annotations

import ast
import bisect
import contextlib
import functools
import io
import re
import threading
import tokenize
from collections import OrderedDict
from collections.abc import Iterator
from dataclasses import dataclass

MAX_CHARS = 1_000_000  # statement text the cache holds at most [characters] (~37 bytes of tree each: ~40 MB)
_CLAUSES = frozenset({"else", "elif", "except", "finally", "interrupt"})  # continue the statement above
PLACEHOLDER = "_"  # what a number literal becomes in a statement's key
#: held while the cache or Scenic's parser name is in use; reentrant for nested blocks
LOCK = threading.RLock()


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


def _plain_string(tok: tokenize.TokenInfo) -> bool:
    """A one-line ASCII string literal without prefix or triple quotes ('ego', "approach"): keyed
    as a placeholder like a number (the actors' names). Not other text: the tokenizer counts
    columns in characters where the parser counts bytes."""
    text = tok.string
    return (text[0] in "'\"" and text[:3] not in ('"""', "'''") and tok.start[0] == tok.end[0]
            and text.isascii())


_UNARY_AFTER = frozenset({"(", "[", "{", ",", "=", ":"})  # a '-' after these is a sign, never a minus


def _negative(before: tuple, tok: tokenize.TokenInfo) -> bool:
    """Whether the number ``tok`` has a sign glued to it where only a sign can be (``(-5.0``,
    ``, -2``): keyed with it, so a point left of the origin and one right of it share a key."""
    op, sign = before
    return (sign is not None and op is not None and sign.type == tokenize.OP and sign.string == "-"
            and sign.end == tok.start and op.type == tokenize.OP and op.string in _UNARY_AFTER)


def split(source: str) -> list[_Statement]:
    """The top-level statements of ``source`` (a compound statement with its clauses, a
    decorated one with its decorators), each with the number literals it holds."""
    out: list[_Statement] = []
    depth, start, end, new_line, decorated = 0, 0, 0, True, False
    numbers: list[tuple[int, int, str]] = []
    before: tuple[tokenize.TokenInfo | None, tokenize.TokenInfo | None] = (None, None)  # the last two tokens
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
        if kind == tokenize.NUMBER and _negative(before, tok):  # -5.0 after '(' ',' ...: one literal
            numbers.append((tok.start[0] - start + 1, tok.start[1] - 1, "-" + tok.string))
        elif kind == tokenize.NUMBER or (kind == tokenize.STRING and _plain_string(tok)):
            numbers.append((tok.start[0] - start + 1, tok.start[1], tok.string))
        before = (before[1], tok)
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


_TUPLE = re.compile(r"\((?:-?_, )*-?_\)")  # a tuple of placeholders: (_, _), (_, -_, _)
_LIST_START = frozenset("([,= ")  # before a '[' that opens a list display (not a subscript)
MIN_RUN = 2  # tuples alike in a row that are written once in the key


@dataclass
class _Collapsed:
    """A key with runs of like tuples in list displays written once, and how to expand it."""

    text: str
    lists: dict[tuple[int, int], list[tuple[int, int]]]  # (row, col) of '[' -> per element (count, stride)
    after: dict[int, list[tuple[int, int]]]  # row -> (end column of a run's first tuple, columns it adds)


def _runs(row_text: str, start: int, places: set[int]) -> tuple[int, list[tuple[str, int]]] | None:
    """The list display whose '[' is at ``start``: (the column of its ']', its elements as
    (text, count) runs), when every element is a tuple of placeholders on this row, else None."""
    col, elements = start + 1, []
    while True:
        m = _TUPLE.match(row_text, col)
        if m is None or not all(col + i in places for i, c in enumerate(m.group()) if c == PLACEHOLDER):
            return None
        if elements and elements[-1][0] == m.group():
            elements[-1] = (m.group(), elements[-1][1] + 1)
        else:
            elements.append((m.group(), 1))
        col = m.end()
        if row_text.startswith("]", col):
            return col, elements
        if not row_text.startswith(", ", col):
            return None
        col += 2


def _collapse(key: str, positions: list[tuple[int, int]]) -> _Collapsed | None:
    """``key`` with each run of :data:`MIN_RUN` or more like tuples in a one-row list display
    written once; None when it has none. Only placeholders of numbers count (``positions``)."""
    by_row: dict[int, set[int]] = {}
    for row, col in positions:
        by_row.setdefault(row, set()).add(col)
    lines = key.split("\n")
    lists: dict[tuple[int, int], list[tuple[int, int]]] = {}
    after: dict[int, list[tuple[int, int]]] = {}
    for row, places in sorted(by_row.items()):
        text, out, col, removed, marks = lines[row - 1], [], 0, 0, []
        search = 0  # where to look for the next list; ``col``: what is copied up to
        while (i := text.find("[(", search)) >= 0:
            found = _runs(text, i, places) if i == 0 or text[i - 1] in _LIST_START else None
            search = i + 1
            if found is None or all(n < MIN_RUN for _, n in found[1]):
                continue
            end, elements = found
            out.append(text[col:i + 1])
            shape: list[tuple[int, int]] = []  # per element of the collapsed list: (count, stride)
            c = i - removed + 1  # where the next element starts in the collapsed row
            for elem, n in elements:
                stride = len(elem) + 2
                for count in ([n] if n >= MIN_RUN else [1] * n):
                    out.append((", " if shape else "") + elem)
                    c += 2 if shape else 0
                    shape.append((count, stride))
                    c += len(elem)
                    if count > 1:  # columns after this tuple move right by the copies
                        marks.append((c, (count - 1) * stride))
            lists[(row, i - removed)] = shape
            removed += sum((count - 1) * stride for count, stride in shape)
            col = search = end
        if not marks:
            continue
        out.append(text[col:])
        lines[row - 1] = "".join(out)
        after[row] = marks
    if not lists:
        return None
    return _Collapsed("\n".join(lines), lists, after)


def _read_names(body: list[ast.stmt]) -> frozenset[tuple[int, int]]:
    """Where a placeholder parsed as a plain name that is read (not a pattern, not a target)."""
    return frozenset((n.lineno, n.col_offset) for stmt in body for n in ast.walk(stmt)
                     if isinstance(n, ast.Name) and n.id == PLACEHOLDER and isinstance(n.ctx, ast.Load)
                     and n.end_lineno == n.lineno and n.end_col_offset == n.col_offset + len(PLACEHOLDER))


_used: set[tuple[str, str]] | None = None  # the keys a :func:`recording` block looked up


def _lookup(key: tuple[str, str]) -> _Parsed | None:
    if _used is not None:
        _used.add(key)
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
        whole, places = _key(text, stmt.numbers), _key_positions(stmt.numbers)
        collapsed = _collapse(whole, places)
        if collapsed is not None:
            body = _collapsed_statement(collapsed, stmt, parse)
            if body is not None:
                return body
        key = ("key", whole)
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


def _collapsed_statement(collapsed: _Collapsed, stmt: _Statement, parse) -> list[ast.stmt] | None:
    """The statement from the parse of its collapsed key; None where a number did not parse as
    a plain name there (the caller then goes on as without the collapse)."""
    key = ("runs", collapsed.text)
    parsed = _lookup(key)
    if parsed is None:
        stats["misses"] += 1
        try:
            parsed = _Parsed(parse(key[1], "exec").body, frozenset())
        except Exception:  # a placeholder where only a number parses
            parsed = _Parsed([], None)
        _store(key, parsed)
    else:
        stats["hits"] += 1
    if parsed.places is None:
        return None
    copy = _Copy(stmt.first - 1, stmt.numbers, collapsed)
    body = copy.many(parsed.body)
    return body if copy.replaced == len(stmt.numbers) else None


class _Copy:
    """Copies of a cached tree, ``rows`` rows further down, a statement's numbers put back (and
    the runs of like tuples of a ``collapsed`` key written out as many times as it has them)."""

    def __init__(self, rows: int, numbers: list[tuple[int, int, str]] = (), collapsed: _Collapsed | None = None):
        self.rows = rows
        self.constants: dict[tuple[int, int], tuple[str, int]] = {}
        self.moves: dict[int, tuple[list[int], list[int]]] = {}  # row -> (key columns, shifts)
        for (row, kcol), (_, col, num) in zip(_key_positions(numbers), numbers, strict=True):
            self.constants[(row, kcol)] = (num, col)
            cols, shifts = self.moves.setdefault(row, ([], []))
            cols.append(kcol + len(PLACEHOLDER))  # columns from here on move right
            shifts.append(col + len(num) - cols[-1])
        self.lists = collapsed.lists if collapsed is not None else {}
        self.after = collapsed.after if collapsed is not None else {}
        self.replaced = 0  # numbers put back

    def column(self, row: int, col: int) -> int:
        """Where column ``col`` of the key's row ``row`` is in the statement."""
        moved = self.moves.get(row)
        if moved is None:
            return col
        i = bisect.bisect_right(moved[0], col)
        return col + moved[1][i - 1] if i else col

    def key_column(self, row: int, col: int, extra: int) -> int:
        """Where column ``col`` of the collapsed key's row ``row`` is in the whole key (``extra``:
        the columns of the copies of a run's tuple before this one)."""
        marks = self.after.get(row)
        if marks:
            col += sum(add for end, add in marks if col > end)
        return col + extra

    def many(self, body: list[ast.stmt]) -> list[ast.stmt]:
        return [self.node(s) for s in body]

    def node(self, node, extra: int = 0):
        if isinstance(node, list):
            return [self.node(x, extra) for x in node]
        if isinstance(node, tuple):
            return tuple(self.node(x, extra) for x in node)
        if not isinstance(node, ast.AST):
            return node
        if self.constants and isinstance(node, ast.Name) and node.id == PLACEHOLDER:
            kcol = self.key_column(node.lineno, node.col_offset, extra) if self.after else node.col_offset
            hit = self.constants.get((node.lineno, kcol))
            if hit is not None and (not self.after or isinstance(node.ctx, ast.Load)):  # as Scenic's grammar makes a number atom
                num, col = hit
                self.replaced += 1
                row = node.lineno + self.rows
                if num.startswith("-"):  # a signed number: the sign applied to the number
                    operand = ast.Constant(value=ast.literal_eval(num[1:]), lineno=row, col_offset=col + 1,
                                           end_lineno=row, end_col_offset=col + len(num))
                    return ast.UnaryOp(op=ast.USub(), operand=operand, lineno=row, col_offset=col,
                                       end_lineno=row, end_col_offset=col + len(num))
                return ast.Constant(value=ast.literal_eval(num), lineno=row,
                                    col_offset=col, end_lineno=node.end_lineno + self.rows,
                                    end_col_offset=col + len(num))
        cls = node.__class__
        new = cls.__new__(cls)
        fields = new.__dict__
        shape = self.lists.get((node.lineno, node.col_offset)) if self.lists and cls is ast.List else None
        for k, v in node.__dict__.items():
            if shape is not None and k == "elts":  # a collapsed run: its tuple once per copy
                fields[k] = [self.node(elt, extra + i * stride)
                             for (count, stride), elt in zip(shape, v, strict=True) for i in range(count)]
            else:
                fields[k] = self.node(v, extra) if isinstance(v, (ast.AST, list, tuple)) else v
        if "lineno" in cls._attributes:
            for row_attr, col_attr in (("lineno", "col_offset"), ("end_lineno", "end_col_offset")):
                row = fields.get(row_attr)
                if row is None:
                    continue
                col = fields.get(col_attr)
                if col is not None and (self.after or self.moves):
                    if self.after:
                        col = self.key_column(row, col, extra)
                    fields[col_attr] = self.column(row, col) if self.moves else col
                fields[row_attr] = row + self.rows
        return new


def parse_module(source: str, parse) -> ast.Module:
    """``source`` parsed as ``parse(text, "exec")`` (Scenic's parser) parses it, one cached
    top-level statement at a time."""
    if "\r" in source or "\f" in source:  # line ends the statement split does not count as Scenic does
        return parse(source, "exec")
    lines = source.split("\n")
    body: list[ast.stmt] = []
    with LOCK:
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

    with LOCK:
        original = translator.parse_string
        if getattr(original, "_regen_cached", False):  # nested: the outer block serves
            yield
            return
        with _swapped(translator, original):
            yield


@contextlib.contextmanager
def _swapped(translator, original) -> Iterator[None]:
    """Scenic's parser name pointed at the cache for the block (:func:`cached_parsing`)."""

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


@contextlib.contextmanager
def recording() -> Iterator[list[tuple[tuple[str, str], _Parsed]]]:
    """Yields a list that, as the block ends, holds the cache entries its parses used (for
    :mod:`regen.driving.simulation.scenic_disk` to keep). The parses must run in this thread."""
    global _used
    got: list[tuple[tuple[str, str], _Parsed]] = []
    with LOCK:
        outer, _used = _used, set()
        try:
            yield got
        finally:
            used, _used = _used, outer
            got.extend((k, _cache[k]) for k in used if k in _cache)


def are_entries(entries: object) -> bool:
    """Whether ``entries`` is a list of cache entries as :func:`recording` gives them."""
    return isinstance(entries, list) and all(
        isinstance(e, tuple) and len(e) == 2 and isinstance(e[0], tuple) and len(e[0]) == 2
        and all(isinstance(k, str) for k in e[0]) and isinstance(e[1], _Parsed)
        and isinstance(e[1].body, list) for e in entries)


def preload(entries: list[tuple[tuple[str, str], _Parsed]]) -> None:
    """Put parses kept by an earlier process into the cache (those it already holds stay)."""
    with LOCK:
        for key, parsed in entries:
            if key not in _cache:
                _store(key, parsed)


def clear() -> None:
    """Empty the cache (tests)."""
    global _cached_chars
    with LOCK:
        _cache.clear()
        _split_cached.cache_clear()
        _cached_chars = 0
        for k in stats:
            stats[k] = 0


__all__ = ["LOCK", "MAX_CHARS", "are_entries", "cached_parsing", "clear", "parse_module", "preload", "recording", "split",
           "stats"]
