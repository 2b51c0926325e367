"""Scenic's translation of a module to Python bytecode, cached per source text for the process.

Where a warm compilation went after the parse cache (:mod:`regen.driving.simulation.parse_cache`,
profiled over a batch of replayed runs, issue 39): Scenic compiles afresh, for every program, the
Newtonian driving world model and the three modules it imports (it drops them after each
compilation, since they read the ``map`` parameter when they run). Their text never changes, yet
each compilation copied their cached parse, translated it to a Python tree, hashed the tree's
``ast.dump``, unparsed it to Python source and compiled that: four fifths of a compilation's
translation work. (The program itself is not unparsed at all: Scenic drops that text for the
top-level module.) What a module *does* (the objects, the road network from the map) happens
when its code runs, and that still runs every time.

Everything before the run is a function of the module's source text and file name only (Scenic's
parser and its translator keep no state between modules), and its products are immutable (a code
object, the tree's hash, the unparsed text), so they are cached on exactly that key. A module that
declares requirements is translated afresh each time: Scenic keeps the requirements' syntax trees
with the scenario, and a shared tree would tie two scenarios together. :func:`cached_compilation`
puts :func:`compile_stream` in place of Scenic's ``compileStream`` for a block; it follows
Scenic 3.1's ``scenic.syntax.translator.compileStream`` step for step, so a program compiles and
runs as it does without it (tests/driving/simulation/test_compile_cache.py).

Scenic's compiler keeps its state in module globals (the veneer), so two compilations must never
overlap: the parse cache's lock (:data:`regen.driving.simulation.parse_cache.LOCK`) is held for
the whole block, and the swapped-in names are restored on the way out. The cache is bounded
(:data:`MAX_CHARS` of source text, least recently used first out). An imported module's
translation is also kept on disk for the next process (:mod:`regen.driving.simulation.scenic_disk`).
"""

from __future__ import annotations

import ast
import contextlib
import hashlib
from collections import OrderedDict
from collections.abc import Iterator
from dataclasses import dataclass

from regen.driving.simulation import parse_cache, scenic_disk
from regen.driving.simulation.parse_cache import LOCK

MAX_CHARS = 2_000_000  # module source the cache holds at most [characters]


@dataclass(frozen=True)
class _Translated:
    code: object  # the module's Python code object
    ast_hash: bytes  # blake2b(4) of ast.dump of the translated tree, as Scenic computes it
    python_source: str | None  # the tree unparsed, as Scenic keeps it on a module


_cache: OrderedDict[tuple[str, bool, str], _Translated] = OrderedDict()  # (file, unparsed, source)
_cached_chars = 0
_preloaded = False  # whether this process has loaded the parses kept on disk
stats = {"hits": 0, "misses": 0, "disk": 0}  # modules served (disk: read from scenic_disk)


def _translate(source: str, filename: str, translator, *, unparse: bool) -> tuple[_Translated, list]:
    """Steps 1-3 of Scenic's compileStream: parse, translate to Python, hash, unparse (where
    the caller keeps the text), compile."""
    scenic_tree = translator.parse_string(source, "exec", filename=filename)
    tree, requirements = translator.compileScenicAST(scenic_tree, filename=filename)
    hasher = hashlib.blake2b(digest_size=4)
    hasher.update(ast.dump(tree).encode())
    python_source = translator.astToSource(tree) if unparse else None
    code = translator.compileTranslatedTree(tree, filename)
    return _Translated(code, hasher.digest(), python_source), requirements


def _lookup(source: str, filename: str, translator, *, unparse: bool) -> tuple[_Translated, list]:
    global _cached_chars
    key = (filename, unparse, source)
    hit = _cache.get(key)
    if hit is not None:
        _cache.move_to_end(key)
        stats["hits"] += 1
        return hit, []
    kept = scenic_disk.read_translation(filename, source) if unparse else None  # modules only
    if kept is not None:
        stats["disk"] += 1
        done, requirements = _Translated(*kept), []
    else:
        stats["misses"] += 1
        done, requirements = _translate(source, filename, translator, unparse=unparse)
        if unparse and not requirements and done.python_source is not None:
            scenic_disk.write_translation(filename, source, done.code, done.ast_hash, done.python_source)
    if not requirements:  # requirements keep their syntax trees: not shared between scenarios
        _cache[key] = done
        _cached_chars += len(source)
        while _cached_chars > MAX_CHARS and len(_cache) > 1:
            (_, _, old), _ = _cache.popitem(last=False)
            _cached_chars -= len(old)
    return done, requirements


def compile_stream(stream, namespace, compileOptions, filename):  # noqa: N803 (Scenic's signature)
    """Scenic's ``compileStream`` with its translation (parse to bytecode) cached per source
    text; executing the module and storing its scenario state happen every time, as in Scenic."""
    from scenic.core import errors
    from scenic.syntax import translator, veneer

    if (errors.verbosityLevel >= 2 or translator.dumpScenicAST or translator.dumpFinalAST
            or translator.dumpASTPython):  # Scenic's own diagnostics: its own function prints them
        return _original(translator)(stream, namespace, compileOptions, filename)
    veneer.activate(compileOptions, namespace)
    try:
        exec(compile(translator.preamble, "<veneer>", "exec"), namespace)
        namespace[translator.namespaceReference] = namespace
        source = stream.read().decode("utf-8")
        # the program compiled as the top-level module: Scenic drops the Python text it returns
        # (``_scenarioFromStream``), a module keeps it (ScenicLoader): unparse only for modules
        done, requirements = _lookup(source, filename, translator,
                                     unparse=namespace.get("__name__") != "__main__")
        translator.executeCodeIn(done.code, namespace)
        translator.storeScenarioStateIn(namespace, requirements, done.ast_hash, compileOptions)
    finally:
        veneer.deactivate()
    return done.code, done.python_source


def _original(translator):
    return getattr(translator.compileStream, "_regen_original", translator.compileStream)


@contextlib.contextmanager
def cached_compilation() -> Iterator[None]:
    """Within this block (one thread's at a time: :data:`~regen.driving.simulation.parse_cache.LOCK`),
    Scenic translates modules through the cache and parses through the statement cache
    (:func:`regen.driving.simulation.parse_cache.cached_parsing`), which the process's first
    block fills with the parses kept on disk (:func:`~regen.driving.simulation.scenic_disk.read_parses`).
    Nested blocks share the outer one's patch; Scenic's names are restored as the outermost
    block ends."""
    from scenic.syntax import translator

    global _preloaded
    with LOCK:
        if getattr(translator.compileStream, "_regen_original", None) is not None:
            yield
            return
        if not _preloaded:  # the parses an earlier process kept (the warm-up program's statements)
            _preloaded = True
            parse_cache.preload(scenic_disk.read_parses() or [])
        original = translator.compileStream

        def swapped(stream, namespace, compileOptions, filename):  # noqa: N803
            return compile_stream(stream, namespace, compileOptions, filename)

        swapped._regen_original = original
        translator.compileStream = swapped
        try:
            with parse_cache.cached_parsing():
                yield
        finally:
            translator.compileStream = original


def clear() -> None:
    """Empty the cache (tests)."""
    global _cached_chars, _preloaded
    with LOCK:
        _cache.clear()
        _cached_chars = 0
        _preloaded = False
        for k in stats:
            stats[k] = 0


__all__ = ["MAX_CHARS", "cached_compilation", "clear", "compile_stream", "stats"]
