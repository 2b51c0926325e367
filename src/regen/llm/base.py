"""The provider interface: the built-in providers implement it the way a plugin would."""

from __future__ import annotations

import logging
import random
import time
from abc import ABC, abstractmethod
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, TypedDict, TypeVar

from regen.errors import ConfigError, ProviderUnreachableError

log = logging.getLogger(__name__)

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"  # the first 8 bytes of every PNG file
TEXT_ONLY_HINT = ("use --text-only or an image-capable provider "
                  "(--llm openai:<model> or anthropic:<model>)")


class _Text(TypedDict):
    role: str  # 'system' | 'user' | 'assistant'
    content: str


class Message(_Text, total=False):
    #: PNG files shown with the text (user messages only), for providers that
    #: :attr:`~Provider.accepts_images`; absent (or empty) in a text-only message, whose cache
    #: key and request body are then exactly those of a message without the field.
    images: list[bytes]


def image_message(text: str, pngs: Sequence[bytes]) -> Message:
    """A user message showing ``pngs`` (the bytes of PNG files) with ``text``; ConfigError for
    bytes that are not a PNG."""
    if isinstance(pngs, bytes | bytearray):
        raise ConfigError("image_message takes a list of PNG files' bytes; put one in a list")
    message: Message = {"role": "user", "content": text, "images": list(pngs)}
    images_of(message)
    return message


def check_png(data: object, what: str = "an image") -> bytes:
    """``data`` if it is the bytes of a PNG file, else ConfigError (only PNG is sent, so that
    every provider is told the same media type)."""
    if not isinstance(data, bytes | bytearray):
        raise ConfigError(f"{what} of a message is {type(data).__name__}, not the bytes of a PNG file")
    if not data.startswith(PNG_SIGNATURE):
        raise ConfigError(f"{what} of a message is not a PNG file (it starts with {bytes(data[:8])!r}); "
                          "pass the bytes of a PNG file (convert other formats first)")
    return bytes(data)


def images_of(message: Message) -> list[bytes]:
    """The PNGs of ``message`` (none for a text-only one), each checked with :func:`check_png`;
    ConfigError for images on a message that is not the user's (no provider takes them)."""
    images = message.get("images") or []
    if not isinstance(images, list | tuple):  # one PNG where a list of them belongs
        raise ConfigError(f"the images of a message are a list of PNG files' bytes, not "
                          f"{type(images).__name__}")
    if images and message.get("role") != "user":
        raise ConfigError(f"a {message.get('role')!r} message carries images; only user messages may")
    return [check_png(png, f"image {i + 1}") for i, png in enumerate(images)]


@dataclass(frozen=True)
class Sampling:
    """Sampling settings; part of the cache key. The paper used temperature 0 (and top-p 0)."""

    temperature: float = 0.0
    top_p: float | None = None  # None: the provider's default (greedy anyway at temperature 0)
    max_tokens: int = 1024
    seed: int = 0


@dataclass
class Completion:
    text: str
    input_tokens: int = 0  # prompt tokens, whether evaluated or reused
    output_tokens: int = 0
    #: Prompt tokens the provider did not evaluate (an in-process model reading a prefix it
    #: has kept); not cached: a cached call reports 0.
    reused_input_tokens: int = 0


class Provider(ABC):
    """A model behind one call. ``name`` is the provider family, ``model`` the model id."""

    name: str = "provider"
    model: str = ""
    #: Whether calls may run concurrently (an in-process model is one at a time).
    concurrent: bool = True
    #: Whether :meth:`complete` takes a ``purpose`` keyword: the kind of call (``event_edges``),
    #: a hint for a provider that keeps state per kind of prompt. Others are called without it.
    takes_purpose: bool = False
    #: Whether messages may carry images (``Message["images"]``). One that reads text only
    #: refuses them (:meth:`check_images`) instead of dropping them; callers that may meet
    #: such a provider check this flag and ask in text only.
    accepts_images: bool = False

    @property
    def id(self) -> str:
        return f"{self.name}:{self.model}"

    @abstractmethod
    def complete(self, messages: list[Message], *, schema: dict[str, Any] | None,
                 sampling: Sampling) -> Completion:
        """One model call. ``schema`` is the JSON schema the answer must follow (if supported)."""

    def check_images(self, messages: Sequence[Message]) -> None:
        """ConfigError if a message carries an image that is not a PNG, or any image while this
        provider reads text only (:attr:`accepts_images`)."""
        count = sum(len(images_of(m)) for m in messages)
        if count and not self.accepts_images:
            raise ConfigError(f"{self.id} reads text only and this call carries {count} image(s); "
                              + TEXT_ONLY_HINT)

    #: Whether :meth:`option_probs` can read the model's next-token probabilities.
    option_probs_supported: bool = False

    def option_probs(self, messages: list[Message], *, prefix: str, options: tuple[str, ...]
                     ) -> tuple[dict[str, float], int]:
        """The model's probability of each option as the next words of its answer after
        ``prefix`` (``{"answer": "``), renormalised over the options, and the prompt's token
        count. Only where :attr:`option_probs_supported`."""
        raise NotImplementedError(f"{self.id} gives no next-token probabilities")


class RetryableError(Exception):
    """A failure worth retrying (timeout, connection error, 429, 5xx)."""

    def __init__(self, message: str, retry_after: float | None = None):
        super().__init__(message)
        self.retry_after = retry_after


T = TypeVar("T")


def with_retries(fn: Callable[[], T], *, what: str, attempts: int = 4, base_delay: float = 0.5,
                 max_delay: float = 20.0, sleep: Callable[[float], None] = time.sleep) -> T:
    """Call ``fn``; on :class:`RetryableError` back off exponentially (with jitter, honoring
    Retry-After) and try again; after ``attempts`` tries raise ProviderUnreachableError."""
    last: RetryableError | None = None
    for i in range(attempts):
        try:
            return fn()
        except RetryableError as exc:
            last = exc
            if i == attempts - 1:
                break
            delay = exc.retry_after if exc.retry_after is not None else base_delay * 2**i
            # clamped: a plugin may pass a negative or NaN Retry-After (NaN ends up max_delay)
            delay = max(0.0, min(max_delay, delay)) * (1 + 0.1 * random.random())
            log.warning("%s failed (%s); retry %d/%d in %.1f s", what, exc, i + 1, attempts - 1, delay)
            sleep(delay)
    raise ProviderUnreachableError(f"{what} failed after {attempts} attempts: {last}. "
                                   "Check the server or network, or use a cached run with --replay.")
