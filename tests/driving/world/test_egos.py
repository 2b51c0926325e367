import pytest

from regen.driving.world.egos import EGO_TEMPLATES, match_template, template_for
from regen.errors import ConfigError


@pytest.mark.parametrize("text,tid", [
    ("the ego-vehicle stops abruptly in the intersection", "stop_in_intersection"),
    ("Ego stops abruptly after turning right", "stop_after_turn"),
    ("the ego vehicle changes lanes while driving forward", "change_lane"),
    ("the ego slows down", "slow_down"),
    ("the ego brakes hard while driving", "stop_abruptly"),
    ("the ego drives forward from stationary", "drive_forward"),
])
def test_keywords_pick_the_template(text, tid):
    assert match_template(text) == tid


def test_no_match_is_a_config_error():
    with pytest.raises(ConfigError, match="no ego template"):
        match_template("the robot waves")


def test_explicit_template_wins_and_unknown_fails():
    assert template_for("anything at all", "slow_down").id == "slow_down"
    with pytest.raises(ConfigError):
        template_for("x", "fly")


def test_six_templates_with_events_inside_their_duration():
    assert set(EGO_TEMPLATES) == {"drive_forward", "slow_down", "stop_abruptly", "stop_after_turn",
                                  "stop_in_intersection", "change_lane"}
    for t in EGO_TEMPLATES.values():
        assert 0 < t.t_event < t.duration


# --- conformance: every registered template, with no edit here for a new one -----------------

import re  # noqa: E402
from pathlib import Path  # noqa: E402

from regen.core import Behavior, CausePath  # noqa: E402
from regen.driving.grounding.fsm_rules import is_reaction  # noqa: E402
from regen.driving.grounding.rules import build_scenario  # noqa: E402
from regen.driving.simulation.scenario import simulate_scenario  # noqa: E402
from regen.driving.world.maps import geometry  # noqa: E402
from regen.driving.world.states import State  # noqa: E402
from regen.verify.monitor import check_fsm  # noqa: E402
from regen.verify.predicates import get_predicate, list_predicates  # noqa: E402

IDS = list(EGO_TEMPLATES)
DRIVING_PREDICATES = {p.name for p in list_predicates("driving")}


def _calls(states: list[State]):
    return [c for _, calls in states for c in calls]


@pytest.mark.parametrize("tid", IDS)
def test_the_example_text_names_its_template(tid):
    assert match_template(EGO_TEMPLATES[tid].example) == tid


@pytest.mark.parametrize("tid", IDS)
def test_timing_route_and_map_are_consistent(tid):
    t = EGO_TEMPLATES[tid]
    times = [s[0] for s in t.schedule]
    assert times == sorted(times) and times[0] == 0.0
    assert 0 < t.t_event < t.duration
    assert len(t.route) >= 2
    g = geometry(t.map)
    assert ("junction" not in t.needs) or g.junction
    assert ("two_lanes" not in t.needs) or g.lanes_per_direction >= 2
    for m in t.junction_maps:  # it can be moved onto every map it names
        moved = t.on_map(m)
        assert moved.map == m and type(moved) is type(t) and moved.t_event == t.t_event


@pytest.mark.parametrize("tid", IDS)
def test_rule_states_use_real_predicates_and_react_in_order(tid):
    t = EGO_TEMPLATES[tid]
    initial, reactions = t.ego_states()
    for c in _calls([initial, *reactions, *t.prelude()]):
        spec = get_predicate(c.name, "driving")
        assert len(c.args) == spec.arity and set(c.params) <= set(spec.params)
        assert c.name not in t.never, f"{tid} uses {c.name}, which it says never holds"
    assert set(t.never) <= DRIVING_PREDICATES and t.reaction_predicates <= DRIVING_PREDICATES
    from regen.core.scenario import AbstractState

    def state(s: State) -> AbstractState:
        return AbstractState(name=s[0], actor="ego", all_of=s[1])

    assert not is_reaction(state(initial), t)
    assert reactions and is_reaction(state(reactions[0]), t)
    assert not any(is_reaction(state(s), t) for s in t.prelude())


@pytest.mark.parametrize("tid", IDS)
def test_the_ego_alone_plays_its_own_states(tid):
    """Simulated with no other actor, the ego passes through its rule states in order."""
    t = EGO_TEMPLATES[tid]
    behavior = Behavior(text=t.example, domain="driving", ego_template=tid)
    path = CausePath(behavior=behavior, events=[t.example])
    scenario = build_scenario(path, [], narrative=t.example, fsm=None, grounder="rule-based", seed=0)
    out = simulate_scenario(scenario)
    verdict = check_fsm(scenario, out.trace)
    assert verdict.status == "verified", verdict.reason


def test_no_template_id_is_compared_outside_its_module():
    src = Path(__file__).parents[3] / "src" / "regen"
    ids = "|".join(IDS)
    pattern = re.compile(rf"\.id\s*(==|!=|in|not in)\s*[\(\[\{{]?\s*['\"]|['\"]({ids})['\"]\s*(==|!=|in)\s*\w+\.id")
    offenders = [f"{p.relative_to(src)}:{i}" for p in src.rglob("*.py") if "egos" not in p.parts
                 for i, line in enumerate(p.read_text().splitlines(), 1) if pattern.search(line)]
    assert not offenders, offenders
