"""Kept prompt prefixes without the model: where a prefix may be reused, which state is loaded,
the budgets, the disk files, and the purpose hint the client gives a provider that takes it."""

from __future__ import annotations

import json

import numpy as np
import pytest

from regen.llm import LLM
from regen.llm.base import Completion, Provider
from regen.llm.providers import local_kv, local_prefix
from regen.llm.providers.local_kv import (
    GROUP,
    MIN_PIECE,
    DiskStates,
    KeptState,
    common_prefix,
    exact_after,
    reuse_point,
)
from regen.llm.providers.local_prefix import MIN_GAIN, PrefixStates, capacity_bytes


def test_a_prefix_is_reused_only_where_the_rest_is_computed_as_from_an_empty_context() -> None:
    assert reuse_point(45, 134, 512) == 40  # on a multiple of GROUP
    assert reuse_point(133, 134, 512) == 112  # the batch after it has MIN_PIECE tokens or more
    assert reuse_point(512, 515, 512) == 512  # ... or starts where a fresh evaluation's does
    assert reuse_point(7, 100, 512) == 0
    assert GROUP % 4 == 0 and MIN_PIECE >= 8  # what was measured: groups of 4, batches of 8


def test_the_exact_length_leaves_out_answers_and_a_prompts_last_tokens() -> None:
    assert exact_after(0, 0, 134, 512) == 128  # the last partial group is left out
    assert exact_after(0, 0, 520, 512) == 512  # a last batch of 8 tokens: left out
    assert exact_after(128, 128, 40, 512) == 168  # continued from an exact prefix
    assert exact_after(168, 168, 1, 512) == 168  # an answer token
    assert exact_after(130, 130, 40, 512) == 130  # not on a group boundary
    assert exact_after(100, 128, 40, 512) == 100  # after tokens that were not exact


class FakeLlama:
    """What PrefixStates uses of a loaded Llama; ``generate`` reuses the prefix the context
    holds as llama-cpp does, tracks the exact length and adds a two-token answer."""

    prefix_hook = None
    prompt_evaluated = None
    n_batch = 512

    def __init__(self) -> None:
        self.input_ids = np.zeros(4096, dtype=np.intc)
        self.n_tokens = self.exact = 0
        self.loaded: list[tuple[int, ...]] = []
        self._ctx = type("Ctx", (), {"kv_cache_seq_rm": lambda self, s, p0, p1: True})()

    @property
    def _input_ids(self) -> np.ndarray:
        return self.input_ids[: self.n_tokens]

    def exact_tokens(self) -> int:
        return min(self.exact, self.n_tokens)

    def reset(self) -> None:
        self.n_tokens = self.exact = 0

    def generate(self, tokens: list[int]) -> None:
        self.prefix_hook(tokens)
        reuse = min(common_prefix(self._input_ids, tokens), len(tokens) - 1)
        self.prompt_evaluated = len(tokens) - reuse
        self.exact = exact_after(self.exact_tokens(), reuse, len(tokens) - reuse, self.n_batch)
        done = [*tokens, 7, 7]
        self.input_ids[: len(done)] = done
        self.n_tokens = len(done)


@pytest.fixture
def fake(monkeypatch) -> FakeLlama:
    def save(llm):
        return KeptState(tuple(int(t) for t in llm._input_ids), llm.exact_tokens(), bytearray(10 * llm.n_tokens))

    def load(llm, state):
        llm.loaded.append(state.tokens)
        llm.input_ids[: len(state.tokens)] = state.tokens
        llm.n_tokens, llm.exact = len(state.tokens), state.limit
        return True

    monkeypatch.setattr(local_kv, "save_state", save)
    monkeypatch.setattr(local_kv, "load_state", load)
    return FakeLlama()


def _call(states: PrefixStates, llm: FakeLlama, purpose: str, tokens: list[int]) -> int:
    with states.call(llm, purpose) as count:
        llm.generate(tokens)
    assert count.prompt == len(tokens)
    return count.reused


SYSTEM = list(range(1000, 1030))  # 30 tokens every prompt opens with
EXAMPLES = list(range(2000, 2100))  # 100 tokens one purpose's prompts share


def _tail(i: int) -> list[int]:
    return list(range(3000 + 100 * i, 3020 + 100 * i))  # 20 tokens of one call's own


def test_an_interleaved_purpose_starts_from_its_own_kept_state(fake) -> None:
    states = PrefixStates(10**6)
    assert _call(states, fake, "judge", SYSTEM + EXAMPLES + _tail(1)) == 0
    assert _call(states, fake, "edges", SYSTEM + _tail(2)) == 24  # the live context, to a group
    # the context now holds "edges"; the judge's kept state shares 130 tokens with the prompt
    assert _call(states, fake, "judge", SYSTEM + EXAMPLES + _tail(3)) == 128
    assert fake.loaded == [tuple(SYSTEM + EXAMPLES + _tail(1))[:144]]  # kept: the exact tokens


def test_a_kept_state_is_loaded_only_where_it_saves_enough(fake) -> None:
    states = PrefixStates(10**6)
    _call(states, fake, "a", SYSTEM + [1] * 40)
    _call(states, fake, "b", SYSTEM + [2] * 40)
    # "a"'s state gives 32 tokens, the live context 24: not worth a load
    assert _call(states, fake, "c", SYSTEM + [1] * 9 + _tail(1)) == 24 and fake.loaded == []
    assert MIN_GAIN == 16
    _call(states, fake, "c", SYSTEM + _tail(2))  # the live context gives 24 again
    assert _call(states, fake, "d", SYSTEM + [1] * 10 + _tail(1)) == 40  # 16 more: loaded
    assert fake.loaded == [tuple(SYSTEM + [1] * 34)]  # "a"'s exact 64 tokens


def test_the_least_recently_used_state_leaves_first_and_none_is_kept_at_zero(fake) -> None:
    states = PrefixStates(2 * 448)  # two states of 32 exact tokens (10 bytes a token + 4 per id)
    for purpose in ("a", "b", "c"):
        _call(states, fake, purpose, [ord(purpose)] * 38)
    assert list(states._kept) == ["b", "c"] and states.nbytes <= states.capacity
    off = PrefixStates(0)
    assert _call(off, fake, "a", [1] * 38) == 0 and off.nbytes == 0 and off.disk is None
    # without kept states the live context is still reused, up to an exact point
    assert _call(off, fake, "a", [1] * 30 + [2] * 20) == 24


def test_the_budget_comes_from_the_environment(monkeypatch) -> None:
    monkeypatch.delenv(local_prefix.ENV, raising=False)
    assert capacity_bytes() == local_prefix.DEFAULT_MB * 2**20
    for raw, want in (("0", 0), ("1.5", 3 * 2**19), ("-3", 0), ("lots", local_prefix.DEFAULT_MB * 2**20)):
        monkeypatch.setenv(local_prefix.ENV, raw)
        assert capacity_bytes() == want


def test_disk_states_round_trip_atomically_and_within_budget(tmp_path) -> None:
    disk = DiskStates(tmp_path, capacity=2 * 1200)  # two files of 1,140 bytes
    names = [disk.name(p, SYSTEM + [i]) for i, p in enumerate(("a", "b", "c"))]
    assert disk.name("a", SYSTEM + [9]) == names[0]  # found by purpose and the prompt's opening
    assert len(set(names)) == 3
    for i, name in enumerate(names):
        disk.write(name, KeptState(tuple(SYSTEM + [i]), 24, bytearray([i]) * 1000))
    assert disk.read(names[2]) == KeptState(tuple(SYSTEM + [2]), 24, bytearray([2]) * 1000)
    assert DiskStates(tmp_path, 1).head(names[2]) == (tuple(SYSTEM + [2]), 24)  # a new process
    left = sorted(p.name for p in tmp_path.iterdir())
    assert names[2] in left and len(left) == 2  # the oldest left; no temporary file stayed
    (tmp_path / names[2]).write_bytes(b"not a state")
    assert DiskStates(tmp_path, 10**6).head(names[2]) is None
    assert DiskStates(tmp_path, 10**6).read(names[2]) is None


def test_two_calls_of_a_purpose_write_their_shared_prefix_to_disk(fake, tmp_path) -> None:
    states = PrefixStates(10**6, DiskStates(tmp_path, 10**6))
    _call(states, fake, "judge", SYSTEM + EXAMPLES + _tail(1))
    assert _call(states, fake, "judge", SYSTEM + EXAMPLES + _tail(2)) == 128
    [file] = tmp_path.glob("*.kv")
    assert DiskStates(tmp_path, 10**6).head(file.name) == (tuple(SYSTEM + EXAMPLES)[:128], 128)
    fresh = FakeLlama()  # a new process: its first judge call starts from the disk state
    assert _call(PrefixStates(10**6, DiskStates(tmp_path, 10**6)), fresh, "judge",
                 SYSTEM + EXAMPLES + _tail(3)) == 128


class _Hinted(Provider):
    name, model, takes_purpose = "hinted", "m", True

    def __init__(self) -> None:
        self.purposes: list[str] = []

    def complete(self, messages, *, schema, sampling, purpose="call") -> Completion:
        self.purposes.append(purpose)
        return Completion(text=json.dumps({"answer": "yes"}))


class _Plain(Provider):  # written before the hint existed: must be called as before
    name, model = "plain", "m"

    def complete(self, messages, *, schema, sampling) -> Completion:
        return Completion(text=json.dumps({"answer": "yes"}))


def test_the_client_tells_the_purpose_only_to_a_provider_that_takes_it() -> None:
    from regen.core.base import Answer

    class Yes(Answer):
        answer: str

    hinted = _Hinted()
    LLM(hinted).ask("q", Yes, purpose="event_edges")
    assert hinted.purposes == ["event_edges"]
    assert LLM(_Plain()).ask("q", Yes, purpose="event_edges").value.answer == "yes"
