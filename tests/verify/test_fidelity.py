"""Verified means the named cause is what the scenario shows: the fidelity rules, the
``unfaithful`` verdict, and the model's yes/no answer where rules cannot decide."""

from __future__ import annotations

import sys
from pathlib import Path

from regen import domains
from regen.core.verdict import Fidelity, Verdict
from regen.verify.fidelity import check_rules, combine, with_fidelity

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "support"))
from driving_chains import FEASIBLE, chain  # noqa: E402

from regen.driving.grounding.rules import ground_rule_based  # noqa: E402

DRIVING = domains.make("driving")
DB = DRIVING.database()
ROBOT = DRIVING.report_hints.robot
VERIFIED = Verdict(feasible=True, status="verified", reason="all stages reached")


def _fidelity(path) -> Fidelity:
    return check_rules(ground_rule_based(path, seed=0), DB, robot=ROBOT)


def test_a_cone_for_a_signal_change_is_unfaithful_and_never_verified() -> None:
    wrong = chain("stop_abruptly", "the traffic signal suddenly changes",
                  ("traffic_cone", {"start_location": ["ahead_same_lane"]}))
    f = _fidelity(wrong)
    assert f.status == "unfaithful"
    assert "names a traffic signal" in f.reason and "traffic_cone" in f.reason
    v = with_fidelity(VERIFIED, f)
    assert (v.feasible, v.status) == (False, "unfaithful")
    assert "traffic_cone" in v.reason and v.fidelity == f


def test_a_state_the_cause_names_must_be_the_state_shown() -> None:
    silent = chain("stop_abruptly", "an ambulance rushes to an emergency call from behind",
                   ("ambulance", {"behavior": ["drive_forward"], "siren": ["off"], "target_speed": ["fast"],
                                  "start_location": ["behind_adjacent_lane"]}))
    f = _fidelity(silent)
    assert f.status == "unfaithful" and "siren = on" in f.reason and "siren = off" in f.reason
    loud = chain("stop_abruptly", "an ambulance rushes to an emergency call from behind",
                 ("ambulance", {"behavior": ["drive_forward"], "siren": ["on"], "target_speed": ["fast"],
                                "start_location": ["behind_adjacent_lane"]}))
    assert _fidelity(loud).status == "faithful"


def test_a_generic_name_accepts_a_kind_of_it_but_not_another_thing() -> None:
    police = chain("stop_abruptly", "a car brakes in front",
                   ("police_car", {"behavior": ["brake_ahead"], "start_location": ["ahead_same_lane"]}))
    assert _fidelity(police).status == "faithful"  # a police car is a car
    debris = chain("stop_abruptly", "a car brakes in front",
                   ("debris", {"start_location": ["ahead_same_lane"]}))
    assert _fidelity(debris).status == "unfaithful"


def test_every_hand_written_chain_is_faithful_or_undecided() -> None:
    for paths in FEASIBLE.values():
        for p in paths:
            assert _fidelity(p).status in ("faithful", "undecided") or p.events[0] == \
                "the traffic light turns green", p.events[0]  # shown green only in its trace


def test_no_asset_named_is_undecided_and_the_models_answer_counts() -> None:
    vague = chain("stop_abruptly", "something unexpected happens ahead",
                  ("debris", {"start_location": ["ahead_same_lane"]}))
    rules = _fidelity(vague)
    assert rules.status == "undecided"
    assert with_fidelity(VERIFIED, rules).status == "verified"
    said_no = Fidelity(status="unfaithful", by="model", reason="the model judged ...")
    assert combine(rules, said_no) == said_no
    assert with_fidelity(VERIFIED, combine(rules, said_no)).status == "unfaithful"
    faithful = Fidelity(status="faithful", reason="x")
    assert combine(faithful, said_no) == faithful  # rules decide where they can


def test_a_state_no_entity_can_have_is_unfaithful_even_when_no_asset_is_named() -> None:
    # the paper's "a distracted driver failing to move despite a green light", shown by the offline
    # model as a green light and pedestrians walking along: no driver anywhere
    cause = "a distracted driver fails to move despite a green light"
    nobody = chain("slow_down", cause, ("traffic_light", {"light_state": ["green"]}),
                   ("pedestrian_group", {"behavior": ["walk_along"], "start_location": ["roadside_ahead"]}))
    f = _fidelity(nobody)
    assert f.status == "unfaithful" and "'distracted' (driver_state = distracted)" in f.reason
    assert with_fidelity(VERIFIED, f).status == "unfaithful"
    # a vehicle that has a driver can show it: the rules then leave it to the model, as before
    car = chain("slow_down", cause, ("sedan", {"behavior": ["drive_forward"], "driver_state": ["distracted"],
                                             "start_location": ["ahead_same_lane"], "target_speed": ["slow"]}))
    f = _fidelity(car)  # ... but the green light is named too, and nothing there is a light
    assert f.status == "unfaithful" and "'green light' (light_state = green)" in f.reason
    assert "driver_state" not in f.reason.split("a state no entity")[0]
    car.entities.append(nobody.entities[0].model_copy(update={"event": cause}))
    assert _fidelity(car).status in ("undecided", "faithful")
    # a named asset decides as before: a swerving cyclist has no driver state and is not flagged by it
    cyclist = chain("slow_down", "a cyclist swerves into the lane",
                    ("bicycle", {"behavior": ["change_lane"], "start_location": ["ahead_adjacent_lane"]}))
    assert "driver_state" not in _fidelity(cyclist).reason


def test_a_scenario_with_only_the_task_object_is_unfaithful() -> None:
    from regen.core.scenario import Entity

    s = ground_rule_based(chain("stop_abruptly", "a child runs across the road",
                                ("child", {"behavior": ["cross_the_road"], "start_location": ["roadside_ahead"]})))
    own = frozenset({"child"})  # as if the child were the robot's own task object
    f = check_rules(s, DB, robot=ROBOT, own=own)
    assert f.status == "unfaithful" and "no entity of its cause" in f.reason
    assert isinstance(s.entities[0], Entity)


def test_a_state_phrase_of_another_actors_primitive_does_not_bind_the_light() -> None:
    runner = chain("stop_in_intersection", "a car runs the red light",
                   ("sedan", {"behavior": ["run_red_light"], "start_location": ["junction_cross_street"]}),
                   ("traffic_light", {"light_state": ["green"]}))
    assert _fidelity(runner).status == "faithful"  # the runner's red, not the ego's green light
    red = chain("stop_in_intersection", "the light turns red",
                ("traffic_light", {"light_state": ["green"]}))
    assert _fidelity(red).status == "unfaithful"  # no one runs it: the light itself must turn red


def test_a_paraphrase_check_flags_another_asset_and_the_pipeline_leaves_it_to_the_model() -> None:
    from regen.core.scenario import Entity

    manip = domains.make("manipulation")
    s = ground_rule_based(chain("stop_abruptly", "the washing is still wet",
                                ("traffic_cone", {"start_location": ["ahead_same_lane"]})))
    db = manip.database()
    # the cast: a trash can where the words mean the laundry
    s = s.model_copy(update={"entities": [Entity(name="trash_can1", asset="trash_can", kind="object")]})
    f = check_rules(s, db, robot="robot", paraphrases=True)
    assert f.status == "unfaithful"
    assert "'washing', a close paraphrase of a laundry" in f.reason
    assert check_rules(s, db, robot="robot").status == "undecided"  # the pipeline's: the model decides


def test_a_motion_named_without_its_actor_needs_someone_who_makes_it() -> None:
    text = "a wrong-way driver is ahead"
    cone = chain("stop_abruptly", text, ("traffic_cone", {"start_location": ["ahead_same_lane"]}))
    f = _fidelity(cone)
    assert f.status == "unfaithful" and "'wrong way' (wrong_way)" in f.reason and "nobody" in f.reason
    car = chain("stop_abruptly", text, ("sedan", {"behavior": ["wrong_way"], "start_location": ["ahead_same_lane"]}))
    assert _fidelity(car).status == "faithful"  # rules decide: the one motion named is made


def test_a_pedestrian_that_steps_onto_the_road_must_cross_not_walk_along() -> None:
    # seen in a real run: the model's walk_along on the sidewalk was verified for this cause
    along = chain("stop_abruptly", "a pedestrian steps onto the road ahead",
                  ("adult", {"behavior": ["walk_along"], "start_location": ["roadside_ahead"]}))
    f = _fidelity(along)
    assert f.status == "unfaithful" and "cross_the_road" in f.reason and "walk_along" in f.reason
    across = chain("stop_abruptly", "a pedestrian steps onto the road ahead",
                   ("adult", {"behavior": ["cross_the_road"], "start_location": ["roadside_ahead"]}))
    assert _fidelity(across).status == "faithful"


def _door(event: str, assets: list[str], properties: dict[str, dict[str, list[str]]] | None = None):
    """'the robot opens the door' because of ``event``, grounded by the rules with ``assets``
    (and the graph's ``properties`` of some of them)."""
    from regen.core import Behavior, CausePath, PathEntity
    from regen.manipulation.grounding.ground import ground_path
    from regen.manipulation.world.tasks import BEHAVIORS

    b = BEHAVIORS["open_door"]
    path = CausePath(behavior=Behavior(text=b.text, domain="manipulation", params={"reward": b.id}),
                     events=[event, b.text],
                     entities=[PathEntity(asset=a, event=event, properties=(properties or {}).get(a, {}))
                               for a in assets])
    return ground_path(path, None, seed=0, relax=False)


def test_a_state_the_words_imply_for_one_asset_binds_that_asset_only() -> None:
    manip = domains.make("manipulation")
    db, robot, own = manip.database(), manip.report_hints.robot, frozenset({"door"})
    show = "the tv show behind the door is too loud"  # a show is a tv that is on
    f = check_rules(_door(show, ["tv"], {"tv": {"power": ["off"]}}), db, robot=robot, own=own)
    assert f.status == "unfaithful" and "'tv show' names power = on" in f.reason
    assert check_rules(_door(show, ["tv"], {"tv": {"power": ["on"]}}), db, robot=robot, own=own).status == "faithful"
    assert db.named_states("desk_lamp", "power", show) == {}  # a lamp has no show
    # 'is on the desk' is a place, not the power: the state phrases are whole and explicit
    assert db.named_states("laptop", "power", "the laptop is on the desk by the door") == {}
    assert db.named_state("window", "articulation", "the window was left ajar") == ("half_open", "ajar")


def test_a_person_or_animal_named_in_words_no_asset_has_must_be_shown() -> None:
    manip = domains.make("manipulation")
    db, robot, own = manip.database(), manip.report_hints.robot, frozenset({"door"})
    plumber = "the plumber is waiting outside to come in"  # a person no asset's names say
    f = check_rules(_door(plumber, ["book", "trash_can"]), db, robot=robot, own=own)
    assert f.status == "unfaithful" and "names a person ('plumber')" in f.reason and "book" in f.reason
    assert with_fidelity(VERIFIED, f).status == "unfaithful"
    for who in ("adult", "visitor", "child"):  # any person plays the plumber
        assert check_rules(_door(plumber, [who]), db, robot=robot, own=own).status == "faithful", who
    # grandma is a name of the adult: the asset named decides, and says so once
    f = check_rules(_door("grandma is waiting outside", ["book"]), db, robot=robot, own=own)
    assert "names a grandma" in f.reason and "('grandma')" not in f.reason
    puppy = "the puppies scratch at the door to come in"
    assert check_rules(_door(puppy, ["pet"]), db, robot=robot, own=own).status == "faithful"
    f = check_rules(_door(puppy, ["adult"]), db, robot=robot, own=own)
    assert f.status == "unfaithful" and "names an animal ('puppies')" in f.reason
    # a spill the words make with a verb is a spill to show, and mopping needs a mop
    spilled = "the dog spilled water by the door"
    f = check_rules(_door(spilled, ["pet"]), db, robot=robot, own=own)
    assert f.status == "unfaithful" and "names a spilled" in f.reason
    assert check_rules(_door(spilled, ["pet", "spill"]), db, robot=robot, own=own).status == "faithful"
    assert [m.asset for m in db.named_in("the hall floor needs mopping")] == ["mop"]
    # a drink knocked over is a spill too, though no word names it
    tipped = "the dog knocked over its water bowl by the door"
    f = check_rules(_door(tipped, ["pet"]), db, robot=robot, own=own)
    assert f.status == "unfaithful" and "implies a spill ('knocked over + water')" in f.reason
    assert check_rules(_door(tipped, ["pet", "spill"]), db, robot=robot, own=own).status == "faithful"
    # an owner or a past doer is not in the scene: the rules leave it undecided
    for event in ("the plumber's book lies by the door", "a book was dropped by the plumber at the door"):
        f = check_rules(_door(event, ["book"]), db, robot=robot, own=own)
        assert f.status != "unfaithful" and "person" not in f.reason, event


def test_a_road_user_carries_a_person_and_an_animal_needs_one() -> None:
    woman = chain("stop_abruptly", "a woman on a bike swerves into the lane",
                  ("bicycle", {"behavior": ["change_lane"], "start_location": ["ahead_adjacent_lane"]}))
    assert _fidelity(woman).status == "faithful"  # the bicycle's rider
    deer = chain("stop_abruptly", "a deer jumps onto the road ahead",
                 ("child", {"behavior": ["cross_the_road"], "start_location": ["roadside_ahead"]}))
    f = _fidelity(deer)
    assert f.status == "unfaithful" and "names an animal ('deer')" in f.reason


def test_a_truck_standing_at_the_roadside_must_stand_still() -> None:
    moving = chain("stop_abruptly", "a parked truck stands at the roadside",
                   ("truck", {"behavior": ["drive_forward"], "start_location": ["ahead_same_lane"]}))
    f = _fidelity(moving)
    assert f.status == "unfaithful" and "behavior = stationary" in f.reason
    still = chain("stop_abruptly", "a parked truck stands at the roadside",
                  ("truck", {"behavior": ["stationary"], "start_location": ["roadside_ahead"]}))
    assert _fidelity(still).status == "faithful"
    # a parked car that pulls out is not held still by the word 'parked'
    assert DB.named_states("sedan", "behavior", "the parked car ahead pulls out into the lane") == {}


def test_a_vehicle_named_as_stopping_abruptly_must_brake_in_front_not_stand_or_change_lane() -> None:
    """Issue 35: 'the truck ahead stops abruptly' was grounded changing lanes (or parked ahead)
    and called faithful because only the entity was checked."""
    cause = "the truck ahead stops abruptly"
    for prim, loc in (("change_lane", "ahead_adjacent_lane"), ("stationary", "ahead_same_lane")):
        f = _fidelity(chain("stop_abruptly", cause, ("truck", {"behavior": [prim], "start_location": [loc]})))
        assert f.status == "unfaithful" and "behavior = brake_ahead" in f.reason and prim in f.reason, f.reason
    braking = chain("stop_abruptly", cause, ("truck", {"behavior": ["brake_ahead"]}))
    assert _fidelity(braking).status == "faithful"


def test_a_light_named_as_malfunctioning_must_be_dark() -> None:
    cause = "the traffic light at the junction malfunctions"
    cycling = chain("stop_abruptly", cause, ("traffic_light", {"light_state": ["turns_red"]}))
    f = _fidelity(cycling)
    assert f.status == "unfaithful" and "light_state = off" in f.reason
    assert _fidelity(chain("stop_abruptly", cause, ("traffic_light", {"light_state": ["off"]}))).status == "faithful"
