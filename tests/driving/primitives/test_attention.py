"""Mental states with effects: a driver's attention is a delay CP-SAT solves between its light
turning green and its moving off; a distracted driver's cause stage is stopped_on_green, the
pictures label it, and a scenario that names a distracted driver but shows an attentive one is
not verified."""

from __future__ import annotations

import json

import numpy as np
import pytest
from driving_chains import chain

from regen.driving.grounding.rules import ground_rule_based
from regen.driving.primitives.shared.attention import START_DELAY

CAUSE = "a distracted driver ahead fails to move despite a green light"


def _path(state: str, light: str = "red"):
    return chain("drive_forward", CAUSE,
                 ("sedan", {"behavior": ["drive_forward"], "start_location": ["ahead_same_lane"],
                            "driver_state": [state], "target_speed": ["moderate"]}),
                 ("traffic_light", {"light_state": [light], "start_location": ["junction_corner"]}))


# a light that turns green, or (for a distracted driver: an attentive one would not be waiting)
# one green from the start
@pytest.mark.parametrize(("state", "light"), [("attentive", "red"), ("distracted", "red"), ("distracted", "green")])
def test_the_solved_start_delay_is_within_the_drivers_bounds(state, light):
    sc = ground_rule_based(_path(state, light))
    green_at = sc.parameters["traffic_light1"]["t"] if light == "red" else 0.0
    delay = sc.parameters["sedan1"]["t"] - green_at
    lo, hi = START_DELAY[state]
    assert lo - 1e-9 <= delay <= hi + 1e-9
    names = [s.name for s in sc.fsm.states if s.actor == "sedan1" and s.cause]
    assert (names[0] == "stopped_on_green") == (state == "distracted")
    order = [c.actor for st in sc.fsm.stages for c in st.conditions]
    if state == "distracted":  # the light shows green before the driver fails to move at it
        assert order.index("traffic_light1") < order.index("sedan1")


@pytest.mark.slow
def test_a_distracted_driver_stays_stopped_on_green_and_the_scenario_verifies(tmp_path):
    pytest.importorskip("scenic")
    from regen.core.trace import Trace
    from regen.pipeline.stages import run_path

    out = run_path(_path("distracted"), tmp_path / "d", pictures=True)
    assert out.verdict.status == "verified", out.verdict.reason
    tr = Trace.model_validate_json((tmp_path / "d" / "trace.json").read_text())
    light = tr.actors["traffic_light1"].states["light_state"]
    speed = np.asarray(tr.actors["sedan1"].speed)
    t_green = next(tr.times[k] for k, s in enumerate(light) if s == "green")
    t_moves = next(tr.times[k] for k, v in enumerate(speed) if v > 0.3)
    assert t_moves - t_green >= START_DELAY["distracted"][0]
    assert set(tr.actors["sedan1"].states["driver_state"]) == {"distracted"}  # what the label reads
    assert (tmp_path / "d" / "bird_eye.gif").exists()
    attentive = run_path(_path("attentive"), tmp_path / "a", pictures=False)
    assert attentive.verdict.status == "unfaithful" and "driver_state = distracted" in attentive.verdict.reason
    verdict = json.loads((tmp_path / "a" / "verdict.json").read_text())
    assert verdict["feasible"] is False


def test_a_model_fsm_gets_the_distracted_drivers_stopped_on_green_stage():
    """The cause stages added to a model's FSM are computed with every role, so a distracted
    driver's stage names the light it waits at (it was computed per actor, and a model-written
    FSM got 'waiting_ahead' instead: a distracted and an attentive driver looked alike)."""
    from regen.assets.database import database_of
    from regen.core.scenario import FSM, AbstractState, PredicateCall, Stage, StateRef
    from regen.driving.grounding.fsm_rules import with_cause_states
    from regen.driving.grounding.model import path_roles
    from regen.driving.grounding.rules import template_of

    path = _path("distracted", "green")
    sc = ground_rule_based(path)
    moving = AbstractState(name="driving", actor="ego", all_of=[PredicateCall(name="moving", args=["ego"])])
    model_fsm = FSM(states=[moving], stages=[Stage(conditions=[StateRef(actor="ego", state="driving")])])
    fsm, added = with_cause_states(model_fsm, path_roles(path, database_of("driving")), template_of(sc))
    names = [s.name for s in fsm.states if s.actor == "sedan1" and s.cause]
    assert names[0] == "stopped_on_green", added
