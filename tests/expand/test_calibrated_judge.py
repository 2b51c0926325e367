"""The event judge of a calibrated model decides by its probability of yes, not its answer."""

from __future__ import annotations

import json

import pytest

from regen.errors import CacheMissError, ConfigError
from regen.expand import calibration
from regen.expand.edges import judge_events
from regen.llm import LLM
from regen.llm.base import Completion, Provider

STOP = "the ego-vehicle stops abruptly while driving forward"


class Weighing(Provider):
    """A model whose P(yes) per candidate is scripted; its written answers always say yes."""

    name = "fake"
    option_probs_supported = True

    def __init__(self, p_yes: dict[str, float]):
        self.model = "weighing"
        self.p_yes = p_yes
        self.weighed: list[str] = []

    def complete(self, messages, *, schema, sampling) -> Completion:
        return Completion(text=json.dumps({"answer": "yes", "reason": "it always agrees"}))

    def option_probs(self, messages, *, prefix, options):
        candidate = messages[-1]["content"].rsplit('Candidate: "', 1)[1].rstrip('"')
        self.weighed.append(candidate)
        assert prefix == calibration.ANSWER_PREFIX and options == ("yes", "no")
        p = self.p_yes[candidate]
        return {"yes": p, "no": 1 - p}, 100


def test_a_calibrated_model_is_decided_by_its_threshold_not_its_yes(monkeypatch, tmp_path) -> None:
    provider = Weighing({"a child runs across the road": 0.81, "a bird sings in a tree": 0.52})
    monkeypatch.setitem(calibration.JUDGE_THRESHOLDS, provider.id, 0.64)
    llm = LLM(provider, cache=tmp_path / "c.sqlite")
    got = judge_events(llm, "driving", [STOP], list(provider.p_yes))
    assert set(got.accepted) == {"a child runs across the road"}
    assert "P(yes) = 0.52 is below its calibrated threshold 0.64" in got.rejected["a bird sings in a tree"]
    assert got.calls["a bird sings in a tree"] != got.calls["a child runs across the road"]
    # replayed from the cache, the same decision without the model
    replay = LLM(provider, cache=tmp_path / "c.sqlite", replay=True)
    before = len(provider.weighed)
    assert judge_events(replay, "driving", [STOP], list(provider.p_yes)).accepted.keys() == got.accepted.keys()
    assert len(provider.weighed) == before
    with pytest.raises(CacheMissError):
        judge_events(replay, "driving", [STOP], ["debris lies in the lane"])


def test_without_a_threshold_the_written_answer_decides(tmp_path) -> None:
    provider = Weighing({"a bird sings in a tree": 0.1})
    got = judge_events(LLM(provider), "driving", [STOP], ["a bird sings in a tree"])
    assert set(got.accepted) == {"a bird sings in a tree"} and not provider.weighed
    assert got.accepted["a bird sings in a tree"] == "it always agrees"


def test_weighing_a_model_that_gives_no_probabilities_is_a_clear_error() -> None:
    from regen.llm.testing import QueuedProvider

    llm = LLM(QueuedProvider([]))
    assert not llm.can_weigh
    with pytest.raises(ConfigError, match="gives no option probabilities"):
        llm.weigh("x", ("yes", "no"), prefix="")
