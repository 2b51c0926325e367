"""Evaluated prompt prefixes of a llama.cpp context: which ones give exactly what a fresh
evaluation gives, how to save and load them, and their files on disk.

llama.cpp's CPU kernels do not compute a token the same way in every batch: the Q4_K matrix
products take the tokens of a batch four at a time and the rest one by one, and batches of fewer
than eight tokens go another way. A prompt evaluated after a reused prefix of 45 tokens gives
logits up to 0.5 apart from a fresh evaluation, and at temperature 0 a different answer
(measured on the README job's ``ground_roles`` prompts; llama-cpp-python reuses any common
prefix). A prefix is therefore reused only where every token after it is computed as in a
fresh evaluation:

- it ends on a multiple of :data:`GROUP` tokens, and the first batch after it has at least
  :data:`MIN_PIECE` tokens or starts where a fresh evaluation's batch starts (the batches are
  cut at multiples of ``n_batch`` from the start of the context, as a fresh evaluation cuts them);
- it holds only tokens a fresh evaluation of a longer prompt computes the same way: not the
  answer (generated one at a time) nor a prompt's last, partial group of four or a last batch of
  fewer than :data:`MIN_PIECE` tokens. :func:`exact_after` tracks that length (``limit``).

GROUP and MIN_PIECE are twice the measured 4 and 8, a margin for other CPU kernels;
``tests/llm/test_prefix_reuse.py`` checks the logits bit for bit.
"""

from __future__ import annotations

import ctypes
import hashlib
import logging
import os
import struct
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

log = logging.getLogger(__name__)

GROUP = 8  # [tokens] a reused prefix ends on a multiple of this (the kernels group 4)
MIN_PIECE = 16  # [tokens] the least batch after a reused prefix (fewer than 8 go another way)
SIGNATURE = 16  # [tokens] a disk state is found by purpose and the prompt's first tokens
_MAGIC = b"REGENKV2"


def common_prefix(a: Any, b: Any) -> int:
    """How many leading tokens two token sequences share."""
    n = min(len(a), len(b))
    if n == 0:
        return 0
    diff = np.flatnonzero(np.asarray(a[:n], dtype=np.int64) != np.asarray(b[:n], dtype=np.int64))
    return int(diff[0]) if diff.size else n


def _first_batch_end(start: int, end: int, n_batch: int) -> int:
    return min(end, (start // n_batch + 1) * n_batch)


def reuse_point(shared: int, n: int, n_batch: int) -> int:
    """The longest prefix of at most ``shared`` tokens that a prompt of ``n`` tokens may start
    from and still be evaluated exactly as from an empty context (0: none)."""
    k = min(shared, n - 1)
    k -= k % GROUP
    while k > 0 and k % n_batch and _first_batch_end(k, n, n_batch) - k < MIN_PIECE:
        k -= GROUP
    return max(k, 0)


def exact_after(limit: int, start: int, n_new: int, n_batch: int) -> int:
    """The new exact length after ``n_new`` tokens were evaluated after ``start`` (batches cut at
    multiples of ``n_batch``), when the first ``limit`` tokens were exact before."""
    limit = min(limit, start)
    end = start + n_new
    if n_new == 0 or limit < start or start % GROUP:
        return limit
    if start % n_batch and _first_batch_end(start, end, n_batch) - start < MIN_PIECE:
        return limit  # answer tokens, one at a time, land here
    last = (end - 1) // n_batch * n_batch  # where the last batch starts
    return end - end % GROUP if end - last >= MIN_PIECE else max(last, start)


@dataclass(frozen=True)
class KeptState:
    """The KV cache of sequence 0 holding exactly ``tokens`` (``llama_state_seq_get_data``), of
    which the first ``limit`` are as a fresh evaluation computes them."""

    tokens: tuple[int, ...]
    limit: int
    data: bytearray

    @property
    def nbytes(self) -> int:
        return len(self.data) + 4 * len(self.tokens)


def save_state(llm: Any) -> KeptState:
    """The live context of ``llm`` (a Llama with ``exact_tokens``) as a :class:`KeptState`."""
    import llama_cpp

    ctx = llm._ctx.ctx  # noqa: SLF001 (llama-cpp exposes no public context handle)
    size = int(llama_cpp.llama_state_seq_get_size(ctx, 0))
    data = bytearray(size)
    written = int(llama_cpp.llama_state_seq_get_data(ctx, (ctypes.c_uint8 * size).from_buffer(data), size, 0))
    if written != size:
        del data[written:]
    return KeptState(tuple(int(t) for t in llm._input_ids), llm.exact_tokens(), data)  # noqa: SLF001


def load_state(llm: Any, state: KeptState) -> bool:
    """Make ``state`` the only content of the context of ``llm``; False (and an empty context,
    which llama-cpp evaluates again) where llama.cpp refuses it."""
    import llama_cpp

    ctx = llm._ctx.ctx  # noqa: SLF001
    # the cells are freed, not zeroed, as llama-cpp's own reset does: the state fills cells 0..n-1
    llama_cpp.llama_memory_clear(llama_cpp.llama_get_memory(ctx), False)
    size = len(state.data)
    read = int(llama_cpp.llama_state_seq_set_data(ctx, (ctypes.c_uint8 * size).from_buffer(state.data), size, 0))
    # the logits are not part of a sequence state: at least one token is evaluated after a load
    llm._requires_eval = True  # noqa: SLF001
    if read != size:
        llm.n_tokens, llm.exact = 0, 0
        log.debug("llama.cpp refused a kept prefix state (%d of %d bytes read)", read, size)
        return False
    llm.input_ids[: len(state.tokens)] = state.tokens
    llm.n_tokens, llm.exact = len(state.tokens), state.limit
    return True


class DiskStates:
    """Prefixes on disk, one file per purpose and prompt opening, within a byte budget.

    The folder is specific to the model file, llama-cpp-python's version and the context size
    (:func:`regen.llm.providers.local_prefix.disk_folder`), so a state is only loaded into the
    kind of context that wrote it; llama.cpp checks the layer count and cache types again."""

    def __init__(self, folder: Path, capacity: int):
        self.folder = folder
        self.capacity = capacity  # [bytes]
        self._heads: dict[str, tuple[tuple[int, ...], int] | None] = {}  # name -> (tokens, limit)

    @staticmethod
    def name(purpose: str, tokens: Any) -> str:
        head = ",".join(str(int(t)) for t in tokens[:SIGNATURE])
        return hashlib.sha256(f"{purpose}\n{head}".encode()).hexdigest()[:20] + ".kv"

    def head(self, name: str) -> tuple[tuple[int, ...], int] | None:
        """The tokens and exact length of the state stored under ``name``, read once."""
        if name not in self._heads:
            self._heads[name] = None
            try:
                with open(self.folder / name, "rb") as f:
                    if f.read(len(_MAGIC)) == _MAGIC:
                        n, limit = struct.unpack("<II", f.read(8))
                        tokens = tuple(np.frombuffer(f.read(4 * n), dtype="<i4").tolist())
                        self._heads[name] = (tokens, limit) if len(tokens) == n else None
            except (OSError, struct.error, ValueError) as exc:
                log.debug("prefix state %s unreadable: %s", name, exc)
        return self._heads[name]

    def read(self, name: str) -> KeptState | None:
        try:
            raw = (self.folder / name).read_bytes()
            if not raw.startswith(_MAGIC):
                return None
            n, limit = struct.unpack_from("<II", raw, len(_MAGIC))
            start = len(_MAGIC) + 8
            tokens = tuple(np.frombuffer(raw, dtype="<i4", count=n, offset=start).tolist())
            return KeptState(tokens, limit, bytearray(raw[start + 4 * n:]))
        except (OSError, struct.error, ValueError) as exc:
            log.debug("prefix state %s unreadable: %s", name, exc)
            return None

    def write(self, name: str, state: KeptState) -> None:
        """Write atomically (a reader never sees half a file), then keep the folder in budget."""
        if state.nbytes > self.capacity:
            return
        try:
            self.folder.mkdir(parents=True, exist_ok=True)
            tmp = self.folder / f".{name}.{os.getpid()}.tmp"
            with open(tmp, "wb") as f:
                f.write(_MAGIC + struct.pack("<II", len(state.tokens), state.limit))
                f.write(np.asarray(state.tokens, dtype="<i4").tobytes())
                f.write(state.data)
            os.replace(tmp, self.folder / name)
            self._heads[name] = (state.tokens, state.limit)
            self._trim()
        except OSError as exc:  # a full or read-only disk costs speed, never the call
            log.debug("prefix state %s not written: %s", name, exc)

    def _trim(self) -> None:
        files = sorted((p.stat().st_mtime, p) for p in self.folder.glob("*.kv"))
        total = sum(p.stat().st_size for _, p in files)
        for _, path in files[:-1]:  # the newest stays
            if total <= self.capacity:
                break
            total -= path.stat().st_size
            path.unlink(missing_ok=True)
            self._heads.pop(path.name, None)
