"""Greedy decoding under a JSON grammar that asks the grammar about the best token first.

llama-cpp-python's sampler chain applies the grammar to every token of the vocabulary at every
step (152k for Qwen2.5) before it takes the best one. At temperature 0 only the best allowed token
matters, so this sampler takes the best token, asks the grammar about that one alone and applies
the grammar to the whole vocabulary only when it is refused. The chosen token is the same one
(ties go to the lowest id in both); ``benchmarks/bench_llm.py`` prints the time it saves.
"""

from __future__ import annotations

import ctypes
import functools
from typing import Any

import numpy as np


class GrammarFirstGreedy:
    """Drop-in for ``llama_cpp._internals.LlamaSampler`` at temperature 0 with a grammar and no
    penalties: ``sample(ctx, idx)`` returns the token and advances the grammar."""

    def __init__(self, model: Any, grammar: Any, n_vocab: int):
        import llama_cpp

        self._lib = llama_cpp
        self._grammar = llama_cpp.llama_sampler_init_grammar(
            model.vocab, grammar._grammar.encode("utf-8"), grammar._root.encode("utf-8"))  # noqa: SLF001
        if not self._grammar:
            raise ValueError("llama.cpp refused the grammar")
        self._n_vocab = n_vocab
        self._one = (llama_cpp.llama_token_data * 1)()
        self._all: Any = None  # the whole vocabulary, built on the first refusal
        self._view: Any = None

    def _apply(self, data: Any, size: int) -> None:
        arr = self._lib.llama_token_data_array(data=data, size=size, selected=-1, sorted=False)
        self._lib.llama_sampler_apply(self._grammar, ctypes.byref(arr))

    def sample(self, ctx: Any, idx: int = -1) -> int:
        logits = np.ctypeslib.as_array(self._lib.llama_get_logits_ith(ctx.ctx, idx), shape=(self._n_vocab,))
        best = int(np.argmax(logits))
        self._one[0].id, self._one[0].logit, self._one[0].p = best, float(logits[best]), 0.0
        self._apply(self._one, 1)
        if not np.isfinite(self._one[0].logit):  # refused: the grammar over every token, then the best
            if self._all is None:  # built once: the ids stay, the grammar only lowers logits
                self._all = (self._lib.llama_token_data * self._n_vocab)()
                self._view = np.ctypeslib.as_array(self._all).view(
                    np.dtype([("id", np.int32), ("logit", np.float32), ("p", np.float32)]))
                self._view["id"] = np.arange(self._n_vocab, dtype=np.int32)
                self._view["p"] = 0.0
            view = self._view
            view["logit"] = logits
            self._apply(self._all, self._n_vocab)
            best = int(np.argmax(view["logit"]))
            if not np.isfinite(view["logit"][best]):
                raise RuntimeError("the grammar allows no token here")
        self._lib.llama_sampler_accept(self._grammar, best)
        return best

    def close(self) -> None:
        if self._grammar:
            self._lib.llama_sampler_free(self._grammar)
            self._grammar = None

    def __del__(self) -> None:
        self.close()


@functools.cache
def llama_class() -> type:
    """``llama_cpp.Llama`` whose greedy, grammar-constrained calls use :class:`GrammarFirstGreedy`
    (every other setting keeps llama-cpp-python's own sampler chain) and whose prompts can start
    from a kept prefix (:class:`~regen.llm.providers.local_prefix.PrefixHooks`)."""
    import llama_cpp

    from regen.llm.providers.local_prefix import PrefixHooks

    class Llama(PrefixHooks, llama_cpp.Llama):
        def _init_sampler(self, **kw: Any) -> Any:
            neutral = (kw.get("repeat_penalty", 1.0) == 1.0 and not kw.get("frequency_penalty")
                       and not kw.get("presence_penalty") and kw.get("logits_processor") is None)
            if kw.get("grammar") is not None and kw.get("temp") == 0.0 and neutral:
                return GrammarFirstGreedy(self._model, kw["grammar"], self._n_vocab)
            return super()._init_sampler(**kw)

    return Llama
