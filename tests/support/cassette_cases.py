"""The expansions recorded from the offline model (scripts/record_cassettes.py writes them,
tests/expand/test_recorded_model.py replays them): one table for both."""

from __future__ import annotations

from regen.core.behavior import Behavior
from regen.expand import Limits

EXPANSIONS = {
    "expand_driving": (Behavior(text="the ego-vehicle stops abruptly while driving forward", domain="driving"),
                       Limits(max_depth=1, max_causes=3, max_entities=3)),
    "expand_manipulation": (Behavior(text="the robot opens the door", domain="manipulation", params={"reward": "open_door"}),
                            Limits(max_depth=1, max_causes=3, max_entities=3)),
    "expand_manipulation_faucet": (Behavior(text="the robot turns on the faucet", domain="manipulation",
                                            params={"reward": "adjust_faucet"}),
                                   Limits(max_depth=1, max_causes=3, max_entities=3)),
    "expand_manipulation_lamp": (Behavior(text="the robot turns on the lamp", domain="manipulation",
                                          params={"reward": "turn_on_lamp"}),
                                 Limits(max_depth=1, max_causes=3, max_entities=3)),
}
