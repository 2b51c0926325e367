import pytest

from regen.driving.world.ego import EGO_TEMPLATES, match_template, template_for
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
