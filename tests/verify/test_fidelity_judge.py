"""The yes/no fidelity judge (:func:`regen.verify.fidelity.ask_model`) without the real model:
which entities it asks about and how they are shown, what it decides from the answers, and its
labeled set replayed from the offline model's recorded answers
(``benchmarks/fidelity_judge.py --record`` writes them)."""

from __future__ import annotations

import json
import sys
from collections import Counter
from importlib import resources
from pathlib import Path

import pytest

from regen import domains
from regen.core import Behavior, CausePath, PathEntity
from regen.core.scenario import FSM, Entity, Scenario
from regen.llm import LLM
from regen.llm.cache import CallCache
from regen.llm.testing import FunctionProvider
from regen.manipulation.grounding.ground import ground_path
from regen.manipulation.world.tasks import BEHAVIORS
from regen.verify.fidelity import ask_model

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "support"))
from driving_chains import chain  # noqa: E402

from regen.driving.grounding.rules import ground_rule_based  # noqa: E402

CASSETTE = Path(__file__).resolve().parents[1] / "data" / "cassettes" / "fidelity_judge_manipulation.json"
LAMP_OFF = ("desk_lamp", {"power": ["off"]})


def _scene(task: str, cause: str, *context: tuple[str, dict[str, list[str]]]) -> Scenario:
    """A manipulation scene as grounding builds it (rules only), with ``context`` entities."""
    b = BEHAVIORS[task]
    path = CausePath(behavior=Behavior(text=b.text, domain="manipulation", params={"reward": b.id}),
                     events=[cause, b.text],
                     entities=[PathEntity(asset=a, event=cause, properties=p) for a, p in context])
    return ground_path(path, None, seed=0)


def _judge(says_yes_to: str = "") -> tuple[LLM, FunctionProvider]:
    """A model that says yes where the thing asked about starts with ``says_yes_to``, else no."""
    def answer(messages) -> dict[str, str]:
        thing = messages[-1]["content"].split("Thing: ", 1)[1]
        return {"answer": "yes" if says_yes_to and thing.startswith(says_yes_to) else "no"}

    provider = FunctionProvider(answer)
    return LLM(provider), provider


def _things(provider: FunctionProvider) -> list[str]:
    return [m[-1]["content"].split("Thing: ", 1)[1].splitlines()[0] for m in provider.requests]


def test_each_context_entity_is_asked_alone_with_its_state() -> None:
    cause = "a new painting on the wall should be shown off tonight"
    scene = _scene("turn_on_lamp", cause, LAMP_OFF, ("adult", {}))
    llm, provider = _judge()
    f = ask_model(scene, llm, robot="robot")
    assert (f.status, f.by) == ("unfaithful", "model")
    # the lamp the robot switches and the table it works at are its task's, not the cause's
    assert sorted(_things(provider)) == ["adult", "desk lamp (power = off)"]  # asked concurrently: any order
    for messages in provider.requests:
        prompt = messages[-1]["content"]
        assert f'Reason: "{cause}"' in prompt and 'Task: "the robot turns on the lamp"' in prompt
    assert "desk lamp (power = off)" in f.reason and f.call_id


def test_one_entity_that_shows_the_cause_is_enough_and_is_named() -> None:
    scene = _scene("open_door", "something furry is scratching to come in", ("cup", {}), ("pet", {}))
    llm, _ = _judge(says_yes_to="pet")
    f = ask_model(scene, llm, robot="robot")
    assert (f.status, f.by) == ("faithful", "model")
    assert "pet shows" in f.reason and "cup" not in f.reason


def test_only_the_task_objects_are_refused_by_rule_without_asking() -> None:
    # issue 35: a pet wanting in was judged shown by the door alone
    scene = _scene("open_door", "something furry is scratching to come in")
    llm, provider = _judge(says_yes_to="door")
    f = ask_model(scene, llm, robot="robot")
    assert (f.status, f.by) == ("unfaithful", "rule")
    assert provider.requests == []
    assert "task's own objects" in f.reason


def test_a_driving_actor_is_shown_with_its_motion() -> None:
    scene = ground_rule_based(chain("stop_abruptly", "someone steps out without looking",
                                    ("adult", {"behavior": ["cross_the_road"], "start_location": ["roadside_ahead"]})))
    llm, provider = _judge(says_yes_to="adult")
    f = ask_model(scene, llm, robot="ego-vehicle")
    assert f.status == "faithful"
    assert _things(provider) == ["adult (cross_the_road)"]  # the ego is never asked about


# --- the labeled set -----------------------------------------------------------------------------


def _cases() -> list[dict]:
    text = resources.files("regen.manipulation").joinpath("data/judge.jsonl").read_text(encoding="utf-8")
    return [json.loads(line) for line in text.splitlines() if line.strip()]


def _scenario(case: dict) -> Scenario:
    behavior = Behavior(text=case["behavior"], domain=case["domain"], params={"reward": case["reward"]})
    return Scenario(id=case["id"], domain=case["domain"], behavior=behavior,
                    causal_graph=[case["cause"], case["behavior"]], narrative="",
                    entities=[Entity.model_validate(e) for e in case["entities"]], fsm=FSM())


def test_the_labeled_set_has_fixed_halves_of_real_scenes() -> None:
    cases = _cases()
    assert len(cases) >= 40 and len({c["id"] for c in cases}) == len(cases)
    db = domains.make("manipulation").database()
    for c in cases:
        context = [e for e in _scenario(c).entities if e.properties.get("role") == "context"]
        assert all(e.asset in db.assets for e in context), c["id"]
        assert (c["kind"] == "own_only") == (not context), c["id"]
    by = Counter((c["split"], c["expected"]) for c in cases)
    for split in ("tune", "test"):
        assert 0.4 <= (by[(split, "yes")] + by[(split, "no")]) / len(cases) <= 0.6
        assert by[(split, "yes")] >= 10 and by[(split, "no")] >= 10
    assert {c["kind"] for c in cases if c["expected"] == "no"} == {"wrong_state", "related", "unrelated", "own_only"}


def test_the_recorded_offline_answers_replay_and_refuse_the_issues_scenes() -> None:
    cache = CallCache(None)
    cache.import_json(CASSETTE)
    llm = LLM("local", cache=cache, replay=True)  # a prompt changed since recording: CacheMissError
    said = {c["id"]: ask_model(_scenario(c), llm, robot="robot") for c in _cases()}
    assert llm.stats.total.model_calls == 0
    assert said["j002"].status == "unfaithful"  # a desk lamp that is off shows no painting shown off
    assert (said["j015"].status, said["j015"].by) == ("unfaithful", "rule")  # a door alone shows no pet
    for split in ("tune", "test"):
        cases = [c for c in _cases() if c["split"] == split]
        called = [c for c in cases if said[c["id"]].status == "faithful"]
        right = [c for c in called if c["expected"] == "yes"]
        # recorded: tune 12 of 13, test 10 of 12 (precision 0.44 and 0.52 before the judge asked
        # per entity)
        assert len(right) / len(called) >= 0.8, split


@pytest.mark.parametrize("answer", ["maybe", "yes, it does"])
def test_an_answer_that_is_not_yes_or_no_is_refused_not_read(answer: str) -> None:
    from regen.errors import MalformedAnswerError

    scene = _scene("turn_on_lamp", "a new painting on the wall should be shown off tonight", LAMP_OFF)
    llm = LLM(FunctionProvider(lambda messages: {"answer": answer}), max_reasks=0)
    with pytest.raises(MalformedAnswerError):
        ask_model(scene, llm, robot="robot")
