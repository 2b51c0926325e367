"""Prompt prefixes the offline model has read, kept so that a later call need not read them again.

llama-cpp-python already skips the tokens a prompt shares with what its context holds (the
previous call's prompt and answer: ``Llama.generate`` compares with ``_input_ids``). Calls of one
purpose share their opening (system prompt, instructions, worked examples), but purposes
interleave (``entity_edges``, ``entity_judge``, ``entity_edges``; ``ground_roles``,
``ground_fsm`` per scenario; case after case in an evaluation), so the context seldom still
holds it. :class:`PrefixStates` keeps, per purpose, the evaluated context of that purpose's last
call (llama.cpp's sequence state: the KV cache of its tokens, 28 KiB per token for
Qwen2.5-Coder-1.5B) and loads it before a call whose prompt shares more tokens with it than with
the live context; llama-cpp then evaluates only the rest. A prefix that two calls of one purpose
shared is also written to disk (beside the model files), so that a new process's first call of
that purpose reads it in milliseconds instead of seconds.

Only whole prefixes are reused (a token's KV depends on every token before it, so text shared
further into a prompt is read again), and only up to a point after which the prompt is computed
exactly as from an empty context (:mod:`regen.llm.providers.local_kv`); this also applies to
llama-cpp's own reuse of the live context, which at any other point changes answers. So greedy
answers are those of a fresh evaluation, whatever came before (``tests/llm/test_prefix_reuse.py``
checks it on recorded prompts); ``benchmarks/bench_prefix.py`` prints what it saves.
``REGEN_LOCAL_PREFIX_CACHE_MB`` bounds the kept states in memory and on disk (each; default
:data:`DEFAULT_MB`); 0 keeps none.
"""

from __future__ import annotations

import hashlib
import logging
import os
import threading
from collections import OrderedDict
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from regen.llm.providers import local_kv
from regen.llm.providers.local_kv import (
    DiskStates,
    KeptState,
    common_prefix,
    exact_after,
    reuse_point,
)

log = logging.getLogger(__name__)

DEFAULT_MB = 256  # [MiB] kept states in memory, and again on disk: ~9,000 tokens of Qwen2.5-1.5B
ENV = "REGEN_LOCAL_PREFIX_CACHE_MB"
MIN_GAIN = 16  # [tokens] a kept state is loaded only when it saves at least this many (~0.3 s)
DISK_MIN = 64  # [tokens] a shared prefix is written to disk from this length (~1 s to read again)


def capacity_bytes() -> int:
    """The budget of kept states [bytes] from ``REGEN_LOCAL_PREFIX_CACHE_MB`` (0: keep none)."""
    raw = os.environ.get(ENV, "").strip()
    try:
        mb = float(raw) if raw else DEFAULT_MB
    except ValueError:
        log.warning("%s=%r is not a number of MiB; using %d", ENV, raw, DEFAULT_MB)
        mb = DEFAULT_MB
    return max(0, int(mb * 2**20))


@dataclass
class CallCount:
    """Prompt tokens of one call: how many there were and how many llama.cpp evaluated."""

    prompt: int = 0
    evaluated: int = 0

    @property
    def reused(self) -> int:
        return max(0, self.prompt - self.evaluated)


class PrefixStates:
    """Per purpose, the evaluated context of its last call, in memory within ``capacity`` bytes
    (the least recently used out first), and the prefixes two calls of a purpose shared on
    ``disk``. One per loaded model; its lock makes that model's calls one at a time."""

    def __init__(self, capacity: int, disk: DiskStates | None = None):
        self.capacity = capacity  # [bytes]
        self.disk = disk if capacity > 0 else None
        self.lock = threading.Lock()
        self._kept: OrderedDict[str, KeptState] = OrderedDict()

    @property
    def nbytes(self) -> int:
        """[bytes] held in memory."""
        return sum(s.nbytes for s in self._kept.values())

    @contextmanager
    def call(self, llm: Any, purpose: str) -> Iterator[CallCount]:
        """Around one completion of ``llm`` (a Llama with :class:`PrefixHooks`): before it
        evaluates its prompt the context starts from the best exact prefix (live or kept),
        after it the context is kept as ``purpose``'s. Yields the call's prompt-token counts,
        filled when the block ends."""
        count = CallCount()
        # a recurrent model cannot drop the tail of its state, so it cannot start from a prefix
        active = not (getattr(llm, "_is_recurrent", False) or getattr(llm, "_is_hybrid", False))

        def before(tokens: list[int]) -> None:
            count.prompt = len(tokens)
            if active:
                self._restore(llm, tokens, purpose)

        with self.lock:
            llm.prefix_hook, llm.prompt_evaluated = before, None
            try:
                yield count
            finally:
                llm.prefix_hook = None
            count.evaluated = count.prompt if llm.prompt_evaluated is None else llm.prompt_evaluated
            if active and self.capacity > 0 and llm.exact_tokens() > 0:
                # the answer and the prompt's last tokens are never reused: not kept
                keep_first(llm, llm.exact_tokens())
                self._keep(purpose, local_kv.save_state(llm))

    def _keep(self, purpose: str, state: KeptState) -> None:
        self._kept.pop(purpose, None)
        if state.nbytes > self.capacity:
            return
        self._kept[purpose] = state
        while self.nbytes > self.capacity:
            self._kept.popitem(last=False)

    def _restore(self, llm: Any, tokens: list[int], purpose: str) -> None:
        """Start the context from the longest exact prefix of ``tokens`` it holds or a kept state
        (memory, else disk) holds, where loading one saves :data:`MIN_GAIN` tokens; write a
        prefix two calls of ``purpose`` shared to disk."""
        n, n_batch = len(tokens), llm.n_batch

        def point(held: Any, limit: int) -> int:
            return reuse_point(min(common_prefix(held, tokens), limit), n, n_batch)

        live = point(llm._input_ids, llm.exact_tokens())  # noqa: SLF001
        best_k, best_key, best = live, None, None
        for key, state in self._kept.items():
            if (k := point(state.tokens, state.limit)) > best_k:
                best_k, best_key, best = k, key, state
        name = head = None
        if self.disk is not None:
            name = self.disk.name(purpose, tokens)
            head = self.disk.head(name)
            if head is not None and point(*head) > best_k and (read := self.disk.read(name)):
                best_k, best_key, best = point(read.tokens, read.limit), None, read
        start = live
        if best is not None and best_k >= live + MIN_GAIN:
            if best_key is not None:
                self._kept.move_to_end(best_key)
            start = best_k if local_kv.load_state(llm, best) else 0
        if name is not None and purpose in self._kept:
            state = self._kept[purpose]
            shared = point(state.tokens, state.limit)
            held = point(*head) if head is not None else 0
            if DISK_MIN <= shared <= start <= shared + MIN_GAIN and held < shared:
                keep_first(llm, shared)
                self.disk.write(name, local_kv.save_state(llm))
                start = shared
        keep_first(llm, start)


def keep_first(llm: Any, k: int) -> None:
    """Keep the first ``k`` tokens of the context (llama-cpp then evaluates from there)."""
    if k <= 0:
        llm.reset()
    elif k < llm.n_tokens:
        llm._ctx.kv_cache_seq_rm(-1, k, -1)  # noqa: SLF001
        llm.n_tokens = k
        llm._requires_eval = True  # noqa: SLF001


class PrefixHooks:
    """Mixin for ``llama_cpp.Llama``: shows a :class:`PrefixStates` the prompt tokens of each
    completion before llama-cpp compares them with its context, cuts evaluations into batches
    at multiples of ``n_batch`` as an evaluation from an empty context cuts them, tracks how
    many leading tokens are exact (:func:`~regen.llm.providers.local_kv.exact_after`) and counts
    the prompt tokens a completion evaluates (the first ``eval`` of a ``generate``)."""

    prefix_states: PrefixStates | None = None
    prefix_hook: Any = None  # set by PrefixStates.call for the length of one completion
    prompt_evaluated: int | None = None
    exact = 0  # leading tokens of the context that a fresh evaluation computes the same way

    def exact_tokens(self) -> int:
        return min(self.exact, self.n_tokens)  # type: ignore[attr-defined]

    def generate(self, tokens: Any, *args: Any, **kwargs: Any) -> Any:
        tokens = list(tokens)
        if self.prefix_hook is not None:
            self.prefix_hook(tokens)
        self.prompt_evaluated = None
        return super().generate(tokens, *args, **kwargs)  # type: ignore[misc]

    def eval(self, tokens: Any) -> None:
        tokens = list(tokens)
        if self.prompt_evaluated is None:
            self.prompt_evaluated = len(tokens)
        start, n_batch = self.n_tokens, self.n_batch  # type: ignore[attr-defined]
        exact = self.exact_tokens()
        first = min(len(tokens), n_batch - start % n_batch)
        for piece in (tokens[:first], tokens[first:]):
            if piece:
                super().eval(piece)  # type: ignore[misc]
        self.exact = exact_after(exact, start, len(tokens), n_batch)

    def reset(self) -> None:
        super().reset()  # type: ignore[misc]
        self.exact = 0


def disk_folder(model: Path, n_ctx: int) -> Path:
    """The folder of the disk states of one model file in a context of ``n_ctx`` tokens."""
    import llama_cpp

    from regen.paths import cache_dir

    st = model.stat()
    ident = f"{model.resolve()}|{st.st_size}|{st.st_mtime_ns}|{llama_cpp.__version__}|{n_ctx}"
    key = hashlib.sha256(ident.encode()).hexdigest()[:16]
    return cache_dir("models") / "prefix-states" / f"{model.stem}-{key}"


def attach(llm: Any, model: Path, n_ctx: int) -> PrefixStates:
    """Give a freshly loaded Llama its :class:`PrefixStates` (budget from the environment)."""
    capacity = capacity_bytes()
    disk = DiskStates(disk_folder(model, n_ctx), capacity) if capacity > 0 else None
    llm.prefix_states = PrefixStates(capacity, disk)
    return llm.prefix_states
