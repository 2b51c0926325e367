"""Structured calls with validation, re-asks, caching, replay, usage accounting, concurrency."""

from __future__ import annotations

import dataclasses
import json
import logging
import threading
import time
import weakref
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Generic, TypeVar

from pydantic import BaseModel, ValidationError

from regen.errors import CacheMissError, ConfigError, MalformedAnswerError, ProviderResponseError
from regen.llm.base import Completion, Message, Provider, Sampling
from regen.llm.cache import CallCache, cache_key
from regen.llm.json_extract import extract_json
from regen.llm.sanitize import clean_text, clean_value, shorten

log = logging.getLogger(__name__)

T = TypeVar("T", bound=BaseModel)
R = TypeVar("R")
I = TypeVar("I")  # noqa: E741

MAX_ECHO_CHARS = 4000  # a re-ask shows the model at most this much of its invalid answer
MAX_PROBLEM_CHARS = 1000  # validation problems quoted in a re-ask or an error message


@dataclass
class PurposeStats:
    calls: int = 0  # requests answered (model or cache)
    model_calls: int = 0  # requests that reached the provider
    cache_hits: int = 0
    reasks: int = 0
    failures: int = 0
    input_tokens: int = 0
    output_tokens: int = 0
    latency: float = 0.0  # [s] summed provider latency (original latency for cache hits)


@dataclass
class UsageStats:
    total: PurposeStats = field(default_factory=PurposeStats)
    by_purpose: dict[str, PurposeStats] = field(default_factory=dict)

    def as_dict(self) -> dict[str, Any]:
        return {"total": vars(self.total).copy(),
                "by_purpose": {k: vars(v).copy() for k, v in sorted(self.by_purpose.items())}}

    def summary(self) -> str:
        t = self.total
        return (f"{t.calls} calls ({t.model_calls} to the model, {t.cache_hits} cached, "
                f"{t.reasks} re-asks), {t.input_tokens} tokens in, {t.output_tokens} out, "
                f"{t.latency:.1f} s model time")


@dataclass
class Answered(Generic[T]):
    value: T
    call_id: str  # cache key of the call whose answer validated
    cached: bool
    attempts: int


@dataclass
class CallEvent:
    purpose: str
    cached: bool
    input_tokens: int
    output_tokens: int
    latency: float


def _format_errors(exc: ValidationError) -> str:
    parts = []
    for err in exc.errors()[:8]:
        loc = ".".join(str(x) for x in err["loc"]) or "(answer)"
        parts.append(f"{shorten(loc, 100)}: {err['msg']}")
    return "; ".join(parts)


_SCHEMAS: weakref.WeakKeyDictionary[type, str] = weakref.WeakKeyDictionary()
_SCHEMAS_LOCK = threading.Lock()


def json_schema_of(model: type[BaseModel]) -> dict[str, Any]:
    """``model.model_json_schema()``, made once per model class (pydantic builds it afresh at
    every call: a third of an expansion replayed from the cache) and handed out as a new dict."""
    with _SCHEMAS_LOCK:
        text = _SCHEMAS.get(model)
    if text is None:
        text = json.dumps(model.model_json_schema())
        with _SCHEMAS_LOCK:
            _SCHEMAS[model] = text
    return json.loads(text)


class LLM:
    """A model client for structured answers.

    Args:
        provider: a provider string (``local``, ``openai:<model>``, ``anthropic:<model>``) or object.
        cache: path of the SQLite cache file, a :class:`CallCache`, or None (memory only).
        replay: forbid model calls; a cache miss raises :class:`CacheMissError`.
        max_reasks: how often an answer that fails validation is sent back with the errors.
        concurrency: how many calls :meth:`map` runs at once (an in-process model runs one at a time).
        sampling: temperature etc.; part of the cache key.
        timeout: [s] per request to a remote provider (None: ``REGEN_LLM_TIMEOUT``, else 120 s);
            only used when ``provider`` is a string. Not part of the cache key.
        provider_options: passed to the provider factory (``base_url``, ``attempts`` ...).

    Every answer is cleaned before it is cached or validated (:mod:`regen.llm.sanitize`): lone
    surrogates replaced, control characters removed, strings cut to
    :data:`~regen.llm.sanitize.MAX_TEXT_CHARS`.
    """

    def __init__(self, provider: str | Provider = "local", *, cache: str | Path | CallCache | None = None,
                 replay: bool = False, max_reasks: int = 2, concurrency: int = 4,
                 sampling: Sampling | None = None, on_call: Callable[[CallEvent], None] | None = None,
                 timeout: float | None = None, **provider_options: Any):
        if isinstance(provider, str):
            from regen.llm.registry import get_provider

            if timeout is not None:
                provider_options["timeout"] = timeout
            provider = get_provider(provider, **provider_options)
        elif timeout is not None or provider_options:
            given = ", ".join(["timeout"] * (timeout is not None) + sorted(provider_options))
            raise ConfigError(f"{given}: a provider object is already built; pass these to its "
                              "constructor (LLM applies them only to a provider it builds from a name)")
        self.provider = provider
        self.cache = cache if isinstance(cache, CallCache) else CallCache(cache)
        self.replay = replay
        self.max_reasks = max_reasks
        self.concurrency = max(1, concurrency)
        self.sampling = sampling or Sampling()
        self.on_call = on_call
        # called before every call that goes to the model (not a cache hit): a batch waits here
        # for its turn at the model (regen.pipeline.run.MainJob), so a cached job never waits
        self.before_model: Callable[[], None] | None = None
        self.stats = UsageStats()
        self._stats_lock = threading.Lock()
        self._provider_lock = threading.Lock()

    # --- one call -----------------------------------------------------------------------------

    def _record(self, purpose: str, completion: Completion, latency: float, cached: bool,
                reask: bool = False, failed: bool = False) -> None:
        with self._stats_lock:
            for s in (self.stats.total, self.stats.by_purpose.setdefault(purpose, PurposeStats())):
                s.calls += 1
                s.model_calls += 0 if cached else 1
                s.cache_hits += 1 if cached else 0
                s.reasks += 1 if reask else 0
                s.failures += 1 if failed else 0
                s.input_tokens += completion.input_tokens
                s.output_tokens += completion.output_tokens
                s.latency += latency
        if self.on_call:
            self.on_call(CallEvent(purpose, cached, completion.input_tokens,
                                   completion.output_tokens, latency))

    def complete(self, messages: list[Message], schema: dict[str, Any] | None, *,
                 purpose: str = "call", reask: bool = False) -> tuple[Completion, str, bool]:
        """A raw cached call: (completion, cache key, whether it came from the cache).

        Images in ``messages`` must be PNGs and the provider must accept them
        (:attr:`Provider.accepts_images`), else ConfigError before the cache is read."""
        self.provider.check_images(messages)
        key = cache_key(self.provider.id, messages, schema, self.sampling)
        # an answer that failed validation for good is replayed, never served to a run that can
        # ask again (regen.llm.cache)
        hit = self.cache.get(key, failed=self.replay)
        if hit is not None:
            completion, latency = hit
            completion = self._clean(completion)  # entries written before cleaning existed
            self._record(purpose, completion, latency, cached=True, reask=reask)
            return completion, key, True
        if self.replay:
            raise CacheMissError(
                f"replay mode: no cached answer for a '{purpose}' call to {self.provider.id} "
                f"(key {key[:12]}). Run without --replay to call the model, or use the cache "
                "file of the run you are replaying.")
        if self.before_model is not None:
            self.before_model()
        hint: dict[str, Any] = {"purpose": purpose} if self.provider.takes_purpose else {}
        start = time.perf_counter()
        if self.provider.concurrent:
            completion = self.provider.complete(messages, schema=schema, sampling=self.sampling, **hint)
        else:
            with self._provider_lock:
                completion = self.provider.complete(messages, schema=schema, sampling=self.sampling,
                                                    **hint)
        latency = time.perf_counter() - start
        completion = self._clean(completion)
        self.cache.put(key, self.provider.id, purpose, completion, latency)
        self._record(purpose, completion, latency, cached=False, reask=reask)
        return completion, key, False

    def _clean(self, completion: Completion) -> Completion:
        """The one place where answer text enters the toolkit: cleaned before caching."""
        if not isinstance(completion.text, str):
            raise ProviderResponseError(f"{self.provider.id} answered with "
                                        f"{type(completion.text).__name__}, not text")
        text = clean_text(completion.text)
        if text == completion.text:
            return completion
        return dataclasses.replace(completion, text=text)

    def ask(self, messages: str | Sequence[Message], schema: type[T], *, purpose: str = "call",
            system: str | None = None) -> Answered[T]:
        """Ask for an answer that validates against ``schema``; re-ask with the errors."""
        msgs: list[Message] = ([{"role": "user", "content": messages}] if isinstance(messages, str)
                               else [dict(m) for m in messages])  # type: ignore[misc]
        if system:
            msgs.insert(0, {"role": "system", "content": system})
        json_schema = json_schema_of(schema)
        problem = ""
        all_cached = True
        invalid: list[str] = []  # cache keys of this call's answers that failed validation
        for attempt in range(self.max_reasks + 1):
            completion, key, cached = self.complete(msgs, json_schema, purpose=purpose,
                                                    reask=attempt > 0)
            all_cached &= cached
            try:
                value = schema.model_validate(clean_value(extract_json(completion.text)))
            except ValidationError as exc:
                problem = shorten(_format_errors(exc), MAX_PROBLEM_CHARS)
            except ValueError as exc:
                problem = shorten(str(exc), MAX_PROBLEM_CHARS)
            else:
                # recovered: the invalid answers before are part of an exchange a rerun replays
                self.cache.mark(invalid, failed=False)
                return Answered(value=value, call_id=key, cached=all_cached, attempts=attempt + 1)
            # marked at once, so that a process killed before the re-ask leaves no answer a
            # rerun would take from the cache
            self.cache.mark([key], failed=True)
            invalid.append(key)
            log.info("answer for %s did not validate (%s); re-asking", purpose, problem)
            msgs = msgs + [
                {"role": "assistant", "content": shorten(completion.text, MAX_ECHO_CHARS)},
                {"role": "user", "content": "Your answer is not valid: " + problem
                 + ". Reply again with only the corrected JSON object."},
            ]
        with self._stats_lock:
            self.stats.total.failures += 1
            self.stats.by_purpose.setdefault(purpose, PurposeStats()).failures += 1
        raise MalformedAnswerError(
            f"{self.provider.id} gave no valid '{purpose}' answer after {self.max_reasks} re-asks: "
            f"{problem}. A stronger model (--llm openai:<model> or anthropic:<model>) usually fixes this.")

    @property
    def can_weigh(self) -> bool:
        """Whether :meth:`weigh` can read option probabilities from this client's model."""
        return self.provider.option_probs_supported

    def weigh(self, messages: str | Sequence[Message], options: tuple[str, ...], *, prefix: str,
              purpose: str = "call", system: str | None = None) -> Answered[dict[str, float]]:
        """The model's probability of each option as its answer's next words after ``prefix``
        (renormalised over ``options``), cached and replayed like an answer."""
        msgs: list[Message] = ([{"role": "user", "content": messages}] if isinstance(messages, str)
                               else [dict(m) for m in messages])  # type: ignore[misc]
        if system:
            msgs.insert(0, {"role": "system", "content": system})
        asked = {"weigh": list(options), "prefix": prefix}  # in the schema's place in the cache key
        self.provider.check_images(msgs)
        key = cache_key(self.provider.id, msgs, asked, self.sampling)
        hit = self.cache.get(key)
        if hit is None and self.replay:
            raise CacheMissError(f"replay mode: no cached probabilities for a '{purpose}' call to "
                                 f"{self.provider.id} (key {key[:12]}). Run without --replay to call the model.")
        if hit is None:
            if not self.can_weigh:
                raise ConfigError(f"{self.provider.id} gives no option probabilities; ask for an answer instead")
            if self.before_model is not None:
                self.before_model()
            start = time.perf_counter()
            with self._provider_lock:
                probs, n_in = self.provider.option_probs(msgs, prefix=prefix, options=tuple(options))
            latency = time.perf_counter() - start
            completion = Completion(text=json.dumps(probs, sort_keys=True), input_tokens=n_in)
            self.cache.put(key, self.provider.id, purpose, completion, latency)
            cached = False
        else:
            completion, latency = hit
            cached = True
        self._record(purpose, completion, latency, cached=cached)
        try:
            raw = json.loads(completion.text)
            probs = {o: float(raw[o]) for o in options}
        except (ValueError, KeyError, TypeError) as exc:
            raise ProviderResponseError(f"cached probabilities for '{purpose}' are unreadable: {exc}") from exc
        return Answered(value=probs, call_id=key, cached=cached, attempts=1)

    def structured(self, messages: str | Sequence[Message], schema: type[T], *, purpose: str = "call",
                   system: str | None = None) -> T:
        """Like :meth:`ask`, returning only the validated value."""
        return self.ask(messages, schema, purpose=purpose, system=system).value

    # --- many calls ---------------------------------------------------------------------------

    def map(self, fn: Callable[[I], R], items: Iterable[I]) -> list[R]:
        """Apply ``fn`` (which makes calls on this client) to items concurrently, keeping order.

        An in-process model serializes its calls anyway; remote providers gain up to
        ``concurrency`` times. The first exception is raised after all calls finished.
        """
        items = list(items)
        workers = min(self.concurrency if self.provider.concurrent else 1, len(items)) or 1
        if workers == 1:
            return [fn(x) for x in items]
        with ThreadPoolExecutor(max_workers=workers, thread_name_prefix="llm") as pool:
            futures = [pool.submit(fn, x) for x in items]
            return [f.result() for f in futures]
