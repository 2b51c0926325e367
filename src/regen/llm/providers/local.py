"""An in-process GGUF model through llama-cpp-python, with schema-constrained decoding.

``local`` is the offline default model; ``local:qwen2.5-0.5b`` a smaller one;
``local:/path/model.gguf`` any GGUF file (checked against ``REGEN_LOCAL_SHA256`` if set).
The model is loaded once per process and used by one call at a time.
"""

from __future__ import annotations

import atexit
import logging
import os
import threading
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from regen.errors import ConfigError, DependencyNotInstalled, ModelFileError
from regen.llm.base import TEXT_ONLY_HINT, Completion, Message, Provider, Sampling
from regen.llm.model_files import (
    DEFAULT_MODEL,
    MODELS,
    check_gguf,
    ensure_model,
    model_hint,
    verify,
)
from regen.llm.providers.local_prefix import attach
from regen.llm.providers.local_sampler import llama_class

log = logging.getLogger(__name__)

_LOADED: dict[tuple[str, int], Any] = {}
_LOAD_LOCK = threading.Lock()


def _threads() -> int:
    return max(1, min(os.cpu_count() or 1, 8))


def _close_all() -> None:
    """Free the loaded models while the interpreter is whole: left to llama-cpp's own finalizer
    at exit, its C bindings are already gone and it prints a TypeError after every command."""
    with _LOAD_LOCK:
        while _LOADED:
            _, llm = _LOADED.popitem()
            try:
                llm.close()
            except Exception as exc:  # noqa: BLE001 (nothing may stop the exit)
                log.debug("closing a local model: %s", exc)


atexit.register(_close_all)


class _Unredirected:
    """Stands in for llama-cpp-python's ``suppress_stdout_stderr``, which points the process's
    file descriptors 1 and 2 (and ``sys.stdout``/``sys.stderr``) at /dev/null while it loads a
    model: every other thread's output in that second was lost with it (seen: a batch's progress
    lines of three resumed behaviors, printed while another behavior loaded the model)."""

    def __init__(self, disable: bool = True):
        pass

    def __enter__(self) -> _Unredirected:
        return self

    def __exit__(self, *exc: object) -> bool:
        return False


_LLAMA_LOG: Any = None  # the ctypes callback llama.cpp logs to (kept referenced)


def _quiet_without_redirection() -> None:
    """llama.cpp's own log goes to this module's logger at debug level (llama-cpp-python would
    print its warnings on stderr), and nothing redirects the process's output while a model loads
    (:class:`_Unredirected`). Once per process."""
    global _LLAMA_LOG
    if _LLAMA_LOG is not None:
        return
    import ctypes

    import llama_cpp
    import llama_cpp._internals
    import llama_cpp.llama
    import llama_cpp.llama_chat_format

    def forward(level: int, text: bytes, user_data: Any) -> None:
        log.debug("llama.cpp: %s", text.decode("utf-8", "replace").rstrip())

    _LLAMA_LOG = llama_cpp.llama_log_callback(forward)
    llama_cpp.llama_log_set(_LLAMA_LOG, ctypes.c_void_p(0))
    for module in (llama_cpp.llama, llama_cpp._internals, llama_cpp.llama_chat_format):
        if hasattr(module, "suppress_stdout_stderr"):
            module.suppress_stdout_stderr = _Unredirected  # type: ignore[attr-defined]


def load_llama(path: Path, n_ctx: int = 4096) -> Any:
    """Load (once per process) and return a ``llama_cpp.Llama``."""
    try:
        llama = llama_class()  # llama_cpp.Llama with the grammar-first greedy sampler
    except ImportError:
        raise DependencyNotInstalled("llama-cpp-python", "local", "the offline model") from None
    key = (str(path), n_ctx)
    with _LOAD_LOCK:
        if key not in _LOADED:
            _quiet_without_redirection()
            start = time.perf_counter()
            try:
                _LOADED[key] = llama(model_path=str(path), n_ctx=n_ctx, n_threads=_threads(),
                                     verbose=False, seed=0)
            except (ValueError, RuntimeError, OSError) as exc:  # llama.cpp: 'Failed to load model'
                raise ModelFileError(f"local model {path} cannot be loaded by llama.cpp ({exc}); "
                                     f"it may be truncated or of an unsupported kind: "
                                     f"{model_hint()}") from None
            log.info("loaded %s in %.1f s", path.name, time.perf_counter() - start)
            attach(_LOADED[key], path, n_ctx)
        return _LOADED[key]


class LocalProvider(Provider):
    name = "local"
    concurrent = False
    takes_purpose = True  # each purpose's prompt prefix is kept (regen.llm.providers.local_prefix)
    accepts_images = False  # a text-only GGUF model: a call with images is refused, never trimmed

    def __init__(self, model: str = "", *, n_ctx: int = 4096, timeout: float | None = None):
        # ``timeout`` is accepted so that one option fits every provider; an in-process call
        # has no request to abandon, so it is not used
        model = model or DEFAULT_MODEL
        self.n_ctx = n_ctx
        if model in MODELS:
            self.model = model
            self._path: Path | None = None
        else:
            path = check_gguf(Path(model).expanduser())
            sha = os.environ.get("REGEN_LOCAL_SHA256")
            if sha:
                verify(path, sha.strip().lower())
            self.model = path.name
            self._path = path

    def check_images(self, messages: Sequence[Message]) -> None:
        """ConfigError for a call with images: the offline model has no vision."""
        if any(m.get("images") for m in messages):
            raise ConfigError("the offline model reads text only; " + TEXT_ONLY_HINT)

    def path(self) -> Path:
        if self._path is None:
            self._path = ensure_model(self.model)
        return self._path

    def llama(self) -> Any:
        return load_llama(self.path(), self.n_ctx)

    def complete(self, messages: list[Message], *, schema: dict[str, Any] | None,
                 sampling: Sampling, purpose: str = "call") -> Completion:
        """One chat completion; the prompt starts from the longest prefix the model has kept
        (``purpose`` names whose state this call's context is kept as)."""
        self.check_images(messages)
        llm = self.llama()
        kwargs: dict[str, Any] = {"messages": messages, "temperature": sampling.temperature,
                                  "max_tokens": sampling.max_tokens, "seed": sampling.seed}
        if sampling.top_p is not None:
            kwargs["top_p"] = sampling.top_p
        if schema is not None:
            kwargs["response_format"] = {"type": "json_object", "schema": schema}
        with llm.prefix_states.call(llm, purpose) as count:
            out = llm.create_chat_completion(**kwargs)
        usage = out.get("usage") or {}
        return Completion(text=out["choices"][0]["message"]["content"] or "",
                          input_tokens=int(usage.get("prompt_tokens", 0)),
                          output_tokens=int(usage.get("completion_tokens", 0)),
                          reused_input_tokens=count.reused)

    option_probs_supported = True

    def option_probs(self, messages: list[Message], *, prefix: str, options: tuple[str, ...]
                     ) -> tuple[dict[str, float], int]:
        """One forward pass over the chat prompt (the model's own chat template) and ``prefix``;
        each option's probability is its first token's, renormalised over the options."""
        self.check_images(messages)
        import llama_cpp
        import numpy as np
        from llama_cpp.llama_chat_format import Jinja2ChatFormatter

        llm = self.llama()
        template = llm.metadata.get("tokenizer.chat_template")
        if not template:
            raise ModelFileError(f"{self.model} carries no chat template; option probabilities need one")
        token_text = llm._model.token_get_text  # noqa: SLF001 (llama-cpp exposes no public getter)
        bos = token_text(llm.token_bos()) if llm.token_bos() >= 0 else ""
        formatter = Jinja2ChatFormatter(template=template, eos_token=token_text(llm.token_eos()),
                                        bos_token=bos, add_generation_prompt=True)
        prompt = formatter(messages=list(messages)).prompt + prefix
        firsts = [llm.tokenize(o.encode("utf-8"), add_bos=False, special=False)[0] for o in options]
        if len(set(firsts)) != len(firsts):
            raise ValueError(f"options {options} share a first token; they cannot be told apart")
        tokens = llm.tokenize(prompt.encode("utf-8"), add_bos=False, special=True)
        with llm.prefix_states.lock:
            llm.reset()  # a fresh context: a following completion reuses this prompt as its prefix
            llm.eval(tokens)
            logits = np.ctypeslib.as_array(llama_cpp.llama_get_logits_ith(llm._ctx.ctx, -1),  # noqa: SLF001
                                           shape=(llm.n_vocab(),)).astype(np.float64)
        chosen = logits[firsts] - logits.max()
        probs = np.exp(chosen) / np.exp(chosen).sum()
        return {o: float(p) for o, p in zip(options, probs, strict=True)}, len(tokens)
