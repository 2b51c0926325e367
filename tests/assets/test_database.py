from __future__ import annotations

import json
from pathlib import Path

import pytest

from regen.assets import load_database
from regen.assets.database import database_of as domain_database
from regen.errors import AssetDatabaseError, ConfigError


@pytest.mark.parametrize("domain", ["driving", "manipulation"])
def test_builtin_databases_load_and_cross_check(domain: str) -> None:
    db = domain_database(domain)
    assert db.entities()
    g = db.graph()
    # every asset hangs under a category, every enumerated state under its property
    for asset in db.assets:
        assert any(g.nodes[p].get("type") == "category" for p in g.predecessors(asset)), asset
    for prop, spec in db.properties.items():
        for s in spec.states or []:
            assert g.has_edge(prop, f"{prop}={s}")


def test_driving_database_has_the_issue_assets() -> None:
    db = domain_database("driving")
    for a in ["sedan", "suv", "truck", "bus", "bicycle", "motorcycle", "ambulance", "police_car",
              "fire_truck", "adult", "child", "pedestrian_group", "debris", "traffic_cone", "barrier",
              "box", "parked_car", "traffic_light", "gnss", "camera"]:
        assert a in db.assets, a
    assert db.property_candidates("ambulance", "siren") == ["on", "off"]
    assert db.property_candidates("traffic_light", "light_state")[:4] == ["red", "yellow", "green", "off"]
    assert "behind_adjacent_lane" in db.property_candidates("ambulance", "start_location")
    assert domain_database("manipulation").property_candidates("cup", "location") is None  # the model proposes these
    assert "cross_the_road" in db.property_candidates("adult", "behavior")
    assert "target_speed" in db.parameters_of("sedan")


def test_manipulation_database_has_articulated_furniture() -> None:
    db = domain_database("manipulation")
    for a in ["door", "window", "drawer", "cabinet", "faucet", "oven", "fridge", "bucket", "pet", "child"]:
        assert a in db.assets, a


def _write(tmp_path: Path, data: dict) -> Path:
    p = tmp_path / "db.json"
    p.write_text(json.dumps(data))
    return p


def _minimal() -> dict:
    return {"name": "mini", "simulator": "x", "categories": {"vehicles": ["car"]},
            "assets": {"car": {"kind": "agent", "description": "car", "properties": ["siren"]}},
            "properties": {"siren": {"description": "s", "states": ["on", "off"]}}}


def test_user_database_loads(tmp_path: Path) -> None:
    db = load_database(_write(tmp_path, _minimal()))
    assert db.entities() == ["car"]


def test_malformed_database_names_file_and_key(tmp_path: Path) -> None:
    data = _minimal()
    data["assets"]["car"]["properties"] = ["siren", "sirne"]
    path = _write(tmp_path, data)
    with pytest.raises(AssetDatabaseError, match=r"db\.json: assets\.car\.properties\[1\]: unknown property 'sirne'"):
        load_database(path)


def test_wrong_type_names_the_key(tmp_path: Path) -> None:
    data = _minimal()
    data["assets"]["car"]["kind"] = "spaceship"
    with pytest.raises(AssetDatabaseError, match=r"assets\.car\.kind"):
        load_database(_write(tmp_path, data))


def test_invalid_json_names_line(tmp_path: Path) -> None:
    p = tmp_path / "bad.json"
    p.write_text('{"name": "x",\n "simulator": }')
    with pytest.raises(AssetDatabaseError, match="bad.json: not valid JSON at line 2"):
        load_database(p)


def test_missing_file_is_a_config_error(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="is not an existing file"):
        load_database(tmp_path / "nope.json")
    with pytest.raises(ConfigError, match=r"neither a domain \(driving, manipulation\) nor an existing file"):
        domain_database("flying")
    with pytest.raises(ConfigError, match="is a folder: give"):
        domain_database(tmp_path)
    with pytest.raises(ConfigError, match="is a folder: give"):
        load_database(tmp_path)


def test_non_utf8_file_says_to_save_it_as_utf8(tmp_path: Path) -> None:
    p = tmp_path / "db.json"
    p.write_bytes(b'{"name": "caf\xe9"}')
    with pytest.raises(ConfigError, match=r"not UTF-8 text \(byte 0xe9 at offset 13\): save it as UTF-8"):
        load_database(p)


def test_deeply_nested_json_is_a_database_error(tmp_path: Path) -> None:
    p = tmp_path / "deep.json"
    p.write_text("[" * 100_000)
    with pytest.raises(AssetDatabaseError, match="deep.json: JSON nested too deeply"):
        load_database(p)


@pytest.mark.parametrize("bad", ["\x00", "\x07", "\x1b", "\x9b", "\ud83d", "\udc15"])
def test_control_characters_and_lone_surrogates_are_refused_with_their_place(tmp_path: Path, bad: str) -> None:
    data = _minimal()
    data["properties"]["siren"]["description"] = f"paint{bad}"
    with pytest.raises(AssetDatabaseError, match=r"properties\.siren\.description = 'paint\\u"):
        load_database(_write(tmp_path, data))  # json.dumps writes the escape, e.g. \ud83d
    data = _minimal()
    data["categories"][f"odd{bad}"] = data["categories"].pop(next(iter(data["categories"])))
    with pytest.raises(AssetDatabaseError, match=r"categories\.odd\\u"):
        load_database(_write(tmp_path, data))


def test_emoji_tabs_and_newlines_are_kept(tmp_path: Path) -> None:
    data = _minimal()
    data["properties"]["siren"]["description"] = "paint 🎨,\tsee\r\nthe manual"
    db = load_database(_write(tmp_path, data))  # json.dumps writes the emoji as a \ud83c\udfa8 pair
    assert db.properties["siren"].description == "paint 🎨,\tsee\r\nthe manual"


def test_driving_start_locations_are_the_simulators_placements() -> None:
    pytest.importorskip("scenic")
    from regen.driving.primitives import LOCATIONS

    assert set(domain_database("driving").properties["start_location"].states) == set(LOCATIONS)


def test_named_states_take_the_longest_phrase_and_must_be_states(tmp_path: Path) -> None:
    db = domain_database("driving")
    assert db.named_state("traffic_light", "light_state", "The light TURNS red ahead") == ("turns_red", "turns red")
    assert db.named_state("traffic_light", "light_state", "a car runs the red light") == ("red", "red light")
    assert db.named_state("traffic_light", "light_state", "a child crosses the road") is None
    assert db.named_state("sedan", "light_state", "the light turns red") is None  # not its property
    data = _minimal()
    data["properties"]["siren"]["named_by"] = {"wailing": ["siren wails"]}
    with pytest.raises(AssetDatabaseError, match="named_by names wailing, which are not states"):
        load_database(_write(tmp_path, data))


def test_an_asset_implies_states_of_its_own_properties_only(tmp_path: Path) -> None:
    data = _minimal()
    asset = next(iter(data["assets"]))
    data["assets"][asset]["implies"] = {"siren": {"wailing": ["siren wails"]}}
    with pytest.raises(AssetDatabaseError, match=rf"assets.{asset}.implies.siren\[0\]: unknown state 'wailing'"):
        load_database(_write(tmp_path, data))
    data["assets"][asset]["implies"] = {"no_such_property": {"on": ["x"]}}
    with pytest.raises(AssetDatabaseError, match="'no_such_property' is not a property"):
        load_database(_write(tmp_path, data))
    data["properties"]["siren"]["named_by"] = {"off": ["siren off"]}
    data["assets"][asset]["implies"] = {"siren": {"on": ["flashing blue"]}}
    db = load_database(_write(tmp_path, data))
    assert db.named_state(asset, "siren", "a car flashing blue comes up behind") == ("on", "flashing blue")
    assert db.named_state(asset, "siren", "a car with its siren off") == ("off", "siren off")  # both kept


def test_behavior_phrases_name_a_motion_only_the_asset_can_make_and_ambiguity_binds_nothing():
    from regen.driving.assets import database as driving

    db = driving()
    assert db.named_state("child", "behavior", "a child runs across the road")[0] == "cross_the_road"
    # an adverb between the verb and 'across' does not hide the crossing
    assert db.named_state("adult", "behavior", "an elderly person walks slowly across the road")[0] == "cross_the_road"
    # a vehicle ahead that stops abruptly brakes in front of the ego; it is not parked there
    assert db.named_state("truck", "behavior", "the truck ahead stops abruptly") == ("brake_ahead", "stops abruptly")
    assert db.named_state("sedan", "behavior", "the car in front slams on its brakes")[0] == "brake_ahead"
    assert db.named_state("bicycle", "behavior", "the cyclist ahead stops abruptly") is None  # not its motion
    assert db.named_state("traffic_light", "light_state", "the traffic light malfunctions") == ("off", "malfunctions")
    assert db.named_state("truck", "behavior", "a truck changes lanes into the ego's path")[0] == "change_lane"
    assert db.named_state("sedan", "behavior", "a car waits for a child crossing the road") is None  # the child's
    event = "a tow truck pulls over to help a broken-down car"  # two actors' motions in one event
    assert db.named_states("tow_truck", "behavior", event) == {"stationary": "broken down", "pull_over": "pulls over"}
    assert db.named_state("tow_truck", "behavior", event) is None
    # a phrase inside a longer one names nothing of its own: 'turns red' is not also 'red'
    assert db.named_states("traffic_light", "light_state", "the traffic light turns red") == {"turns_red": "turns red"}


@pytest.mark.parametrize(("text", "expected"), [
    ("a distracted driver fails to move despite a green light", {"traffic_light", "sedan"}),
    ("the driver ahead is texting", {"sedan"}),
    ("a road hazard ahead", set()),  # one word, and no word of 'hazard warning lights' beside it
    ("a distracted cyclist rides ahead", {"bicycle"}),  # named: the shared state is not re-placed
    ("a cyclist swerves into the lane", {"bicycle"}),  # 'swerves' is the lane change, not a state
])
def test_a_state_several_assets_share_is_held_by_the_generic_one_when_no_actor_is_named(text, expected) -> None:
    """'a distracted driver' names a state every vehicle has and no asset: the first vehicle of
    the database plays it (a green light alone cannot show a distracted driver)."""
    named = domain_database("driving").named_assets(text, robot=["ego-vehicle", "ego"])
    assert set(named) == expected
    if "sedan" in expected:
        assert "driver_state = distracted" in named["sedan"]


@pytest.mark.parametrize(("text", "expected"), [
    ("the dog knocked over its water bowl", {"pet", "spill"}),  # the water went somewhere
    ("the cat tipped over a glass of milk", {"pet", "cup", "spill"}),
    ("the dog knocked over the vase", {"pet"}),  # no liquid: no spill
    ("the dog sleeps beside its water bowl", {"pet"}),  # liquid, nothing knocked over
    ("papers on the desk are blowing away", {"book"}),  # the flat paper object of the database
])
def test_words_that_together_imply_an_asset_name_it(text: str, expected: set[str]) -> None:
    from regen.manipulation.assets import database as manipulation

    assert set(manipulation().named_assets(text, robot=["robot"])) == expected


def test_an_implied_by_entry_needs_two_groups_of_phrases(tmp_path: Path) -> None:
    data = _minimal()
    asset = next(iter(data["assets"]))
    data["assets"][asset]["implied_by"] = [[["knocked over"]]]  # one group: an alias, not an implication
    with pytest.raises(AssetDatabaseError, match="two or more groups"):
        load_database(_write(tmp_path, data))
    data["assets"][asset]["implied_by"] = [[["knocked over"], ["water", "milk"]]]
    db = load_database(_write(tmp_path, data))
    assert [m.key for m in db.implied_by_words("someone knocked over the milk")] == ["knocked over + milk"]
    assert db.implied_by_words("someone knocked over the chair") == []
