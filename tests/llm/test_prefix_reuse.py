"""Kept prompt prefixes change no answer: recorded prompts through the real offline model, with
and without reuse, and the logits bit for bit (deselect with -m 'not model'; CI runs it)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from regen.llm.base import Sampling

pytestmark = [pytest.mark.model, pytest.mark.usefixtures("shared_cache")]

# calls of the README job: event_edges, ground_roles, event_edges, ground_roles; each second call
# of a purpose shares 217 and 45 prompt tokens with the first, but not with the call before.
# Started after 45 tokens (llama-cpp-python's own reuse would), the second ground_roles answer
# is another one; after 40 it is the recorded one.
RECORDED = json.loads((Path(__file__).parent / "data" / "prefix_prompts.json").read_text(encoding="utf-8"))


def _answers(prov, states, *, fresh: bool, calls=None) -> list[tuple[str, int]]:
    """(answer, prompt tokens reused) per recorded call, in the recorded order."""
    llm = prov.llama()
    llm.prefix_states = states
    llm.reset()
    out = []
    for c in calls or RECORDED["calls"]:
        if fresh:
            llm.reset()
        got = prov.complete(c["messages"], schema=c["schema"], sampling=Sampling(), purpose=c["purpose"])
        out.append((got.text, got.reused_input_tokens))
    return out


@pytest.fixture
def prov(monkeypatch):
    pytest.importorskip("llama_cpp", reason="the 'local' extra is not installed")
    from regen.llm.providers.local import LocalProvider

    prov = LocalProvider()
    monkeypatch.setattr(prov.llama(), "prefix_states", prov.llama().prefix_states)  # restored after
    return prov


def test_answers_are_byte_identical_with_and_without_kept_prefixes(prov, tmp_path) -> None:
    from regen.llm.providers.local_kv import DiskStates
    from regen.llm.providers.local_prefix import PrefixStates

    recorded = [c["response"] for c in RECORDED["calls"]]
    cap = 64 * 2**20

    off = _answers(prov, PrefixStates(0), fresh=True)  # every prompt token evaluated
    assert [text for text, _ in off] == recorded
    assert all(reused == 0 for _, reused in off)

    on = _answers(prov, PrefixStates(cap, DiskStates(tmp_path, cap)), fresh=False)
    assert [text for text, _ in on] == recorded
    # the second call of each purpose started from the first one's kept state
    assert on[2][1] == 216 and on[3][1] == 40, on

    # a new process: nothing in memory, the prefix event_edges' calls shared read from disk
    assert list(tmp_path.glob("*.kv"))
    [(text, reused)] = _answers(prov, PrefixStates(cap, DiskStates(tmp_path, cap)), fresh=False,
                                calls=RECORDED["calls"][2:3])
    assert text == recorded[2] and reused == 216


def test_a_prompt_started_from_a_kept_state_has_the_logits_of_a_fresh_evaluation(prov) -> None:
    import llama_cpp
    import numpy as np
    from llama_cpp.llama_chat_format import Jinja2ChatFormatter

    from regen.llm.providers.local_kv import common_prefix, load_state, reuse_point, save_state
    from regen.llm.providers.local_prefix import keep_first

    llm = prov.llama()
    text = llm._model.token_get_text
    chat = Jinja2ChatFormatter(template=llm.metadata["tokenizer.chat_template"], bos_token="",
                               eos_token=text(llm.token_eos()), add_generation_prompt=True)
    first, second = (llm.tokenize(chat(messages=c["messages"]).prompt.encode(), add_bos=False, special=True)
                     for c in RECORDED["calls"][1::2])  # the two ground_roles prompts

    def logits(tokens, state=None) -> np.ndarray:
        llm.reset()
        if state is not None:
            assert load_state(llm, state)
            k = reuse_point(min(common_prefix(state.tokens, tokens), state.limit), len(tokens), llm.n_batch)
            assert k > 0
            keep_first(llm, k)
        llm.eval(tokens[llm.n_tokens:])
        return np.ctypeslib.as_array(llama_cpp.llama_get_logits_ith(llm._ctx.ctx, -1),
                                     shape=(llm.n_vocab(),)).copy()

    def kept(tokens):
        logits(tokens)
        return save_state(llm)

    assert np.array_equal(logits(second, kept(first)), logits(second))  # from 40 of 45 shared
    # 520 tokens: a fresh evaluation's last batch has 8; started after 296, the rest is cut there too
    long = (second + first + second + first)[:520]
    assert np.array_equal(logits(long, kept(long[:300] + first[:50])), logits(long))
