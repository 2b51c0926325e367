"""Each QA layer's answer against a hand-built trace."""

from __future__ import annotations

from dataset_builders import brake, scenario, steady, trace, verdict

from regen.dataset.labels import LABELS, Label, label
from regen.dataset.qa import (
    COMES,
    CROSS_LEFT,
    DIRECTIONS,
    MOTIONS,
    MOVES_ON,
    STAYS,
    counterfactual,
    perception,
    planning,
    prediction,
)
from regen.whatif.record import WhatIf


def _still(x: float, y: float):
    return lambda t: (x, y, 0.0)


def _scene():
    others = {"car1": ("sedan", "agent", lambda t: (20.0 + 10.0 * t, 0.0, 10.0)),  # 20 m ahead at t=0.. moving with the ego
              "light1": ("traffic_light", "object", _still(0.0, 5.0)),
              "bike1": ("bicycle", "agent", _still(-15.0, 0.0)),
              "adult1": ("adult", "agent", lambda t: (12.0 + 10.0 * 5.0, -4.0 + 1.5 * max(0.0, t - 5.0), 1.5))}
    n = 101
    states = {"light1": {"light_state": ["green"] * 60 + ["red"] * (n - 60)}}
    return trace(steady(10.0), others, states)


def test_perception_says_where_each_entity_is_and_its_state() -> None:
    tr = _scene()
    sc = scenario("stop_abruptly")
    got = {q.question.split(" (")[0].removeprefix("Where is "): q.answer for q in perception(sc, tr, Label("stop", 0.0, 2, ""))}
    assert got["car1"].startswith("ahead, 20 m;") and "moving at 10.0 m/s" in got["car1"]
    assert got["light1"].startswith("left, 5 m;") and "stationary" in got["light1"] and "light_state green" in got["light1"]
    assert got["bike1"].startswith("behind, 15 m;")
    overview = next(q.answer for q in perception(sc, tr, Label("stop", 0.0, 2, "")) if q.question.startswith("Which"))
    assert overview.startswith("light1 (traffic_light): left, 5 m; bike1 (bicycle): behind, 15 m")


def test_perception_options_are_the_four_sides_and_the_key_is_the_answers_side() -> None:
    qs = perception(scenario("stop_abruptly"), _scene(), Label("stop", 0.0, 2, ""))
    keys = {q.question.split(" (")[0].removeprefix("Where is "): q.key for q in qs}
    assert keys == {"Which road users and objects are around the ego at t = 0.0 s?": None,  # not scored
                    "light1": "left", "bike1": "behind", "car1": "ahead", "adult1": "ahead"}
    assert all(q.options == DIRECTIONS and q.answer.startswith(q.key) for q in qs if q.key)
    assert qs[0].options == ()


def test_prediction_key_is_the_motion_class_its_answer_leads_with() -> None:
    tr = trace(steady(10.0), {"car1": ("sedan", "agent", steady(8.0, x0=15.0)),
                              "car2": ("sedan", "agent", lambda t: (80.0 - 8.0 * t, 0.0, 8.0)),
                              "adult1": ("adult", "agent", lambda t: (60.0, -4.0 + 1.5 * max(0.0, t - 5.0), 1.5)),
                              "cone1": ("traffic_cone", "object", lambda t: (30.0, 0.0, 0.0))})
    got = {}
    for cause in ("car1", "car2", "adult1", "cone1"):
        sc = scenario("stop_abruptly", cause=cause)
        [q] = prediction(sc, tr, verdict(sc), Label("stop", 5.0, 2, ""))
        assert q.options == MOTIONS
        got[cause] = q.key
    assert got == {"car1": MOVES_ON, "car2": COMES, "adult1": CROSS_LEFT, "cone1": STAYS}


def test_prediction_reads_what_the_cause_actor_does_next() -> None:
    tr = _scene()
    sc = scenario("stop_abruptly", cause="adult1")
    answers = [q.answer for q in prediction(sc, tr, verdict(sc), Label("stop", 5.0, 2, ""))]
    assert len(answers) == 1 and answers[0].startswith("crosses the ego's path towards the ego's left (4.5 m)")
    sc = scenario("stop_abruptly", cause="light1")
    answer = prediction(sc, tr, verdict(sc), Label("stop", 5.0, 2, ""))[0].answer
    assert answer.startswith("stays in place; light_state changes from green to red at t = 6.0 s")


def test_planning_gives_the_label_and_the_cause() -> None:
    sc = scenario("stop_abruptly")
    tr = trace(brake(10.0, 0.0), {"car1": ("sedan", "agent", steady(8.0, x0=15.0))})
    lab = label(sc, tr, verdict(sc))
    [q] = planning(sc, tr, verdict(sc), lab)
    assert q.answer.startswith("stop (brake to a standstill), because a car1 cuts in ahead (car1 ahead, ")
    assert (q.options, q.key) == (tuple(LABELS), "stop")


def test_counterfactual_from_the_but_for_run_and_a_whatif() -> None:
    """A what-if's answer is what the reference driver did in the edited world, never what the
    what-if's scripted ego did (it replays its stop whatever the world does)."""
    sc = scenario("stop_abruptly")
    vd = verdict(sc)
    record = WhatIf(original="/x", edits=[{"op": "remove", "entity": "car1"}], original_status="verified",
                    status="verified", explained=False, causal="not_sufficient", original_explained=True,
                    reason="the reference driver does not stop")
    braking = trace(brake(10.0, 0.0))  # the scripted ego stops in every what-if below
    ignores = verdict(sc, causal="not_sufficient", reacts=False).causal
    still = verdict(sc).causal
    qs = counterfactual(vd, Label("stop", 5.0, 2, ""), [
        {"record": record, "trace": braking, "ego": "ego", "causal": ignores},
        {"record": record.model_copy(update={"explained": True, "causal": "caused"}), "trace": braking,
         "ego": "ego", "causal": still}])
    assert qs[0].question == "What would the ego do if car1 were not there?"
    assert qs[0].answer.startswith("keep_speed: with car1 removed") and "never stops" in qs[0].answer
    assert qs[1].question == "What if we remove car1?"
    assert qs[1].answer.startswith("keep_speed: after the edit (remove car1), the reference driver (IDM) never stops")
    assert "no longer explained" in qs[1].answer
    assert qs[2].answer.startswith("stop:") and "still explained" in qs[2].answer
    assert [q.key for q in qs] == ["keep_speed", "keep_speed", "stop"]
    assert all(q.options == tuple(LABELS) for q in qs)
    unchecked = verdict(sc, causal="not_checked").causal
    for causal in (None, unchecked):  # no reference run in the edited world: not scored
        got = counterfactual(vd, Label("stop", 5.0, 2, ""),
                             [{"record": record, "trace": braking, "ego": "ego", "causal": causal}])
        assert got[1].answer.startswith("unknown") and got[1].key is None
