"""Entities the cause names are the entities grounded: the database decides them whatever the
model answers; an entity only the model adds must pass the yes/no entity judge; the robot's
own task objects are never a cause's entity."""

from __future__ import annotations

from fake_expansion_model import ScriptedModel

from regen.assets.database import database_of
from regen.core.behavior import Behavior
from regen.core.graph import ScenarioGraph
from regen.expand import Limits, expand
from regen.llm import LLM
from regen.llm.testing import FunctionProvider

STOP = "the ego-vehicle stops abruptly while driving forward"
DOOR = "the robot opens the door"


def _expand(domain: str, model: ScriptedModel) -> ScenarioGraph:
    text = {"driving": STOP, "manipulation": DOOR}[domain]
    behavior = Behavior(text=text, domain=domain, **({"reward": "open_door"} if domain == "manipulation" else {}))
    return expand(behavior, LLM(FunctionProvider(model)), limits=Limits(max_depth=1, max_causes=6, max_entities=3))


def _door_cause(cause: str) -> ScenarioGraph:
    """The door opened because of ``cause``, for which the model picks the door itself."""
    model = ScriptedModel(causes={DOOR: [cause]}, entities={cause: ["door"]},
                          values={"location": ["outside the door"]})
    return _expand("manipulation", model)


def _node(graph: ScenarioGraph, label: str, kind: str = "event"):
    return next(n for n in graph.nodes.values() if n.kind == kind and n.label == label)


def test_a_cause_naming_an_alias_grounds_that_asset_whatever_the_model_picks() -> None:
    signal = "the traffic signal suddenly changes"
    model = ScriptedModel(causes={STOP: [signal]}, entities={signal: ["traffic_cone"]},
                          part_of={"traffic_cone": False})
    g = _expand("driving", model)
    light = _node(g, "traffic_light", "entity")
    assert light.status == "accepted"
    assert [(d.action, d.by) for d in light.history] == [("accepted", "database")]
    assert "alias 'traffic signal'" in light.history[0].reason
    cone = _node(g, "traffic_cone", "entity")  # the model's pick: judged, rejected, recorded
    assert cone.status == "rejected" and cone.history[-1].by == "model"
    assert "entity judge answered no" in cone.history[-1].reason
    assert "entity_judge" in model.kinds
    (path,) = g.paths()
    assert [e.asset for e in path.entities] == ["traffic_light"]


def test_a_model_added_entity_that_passes_the_judge_is_kept_after_the_named_one() -> None:
    crash = "a cyclist is hit by a car ahead"
    model = ScriptedModel(causes={STOP: [crash]}, entities={crash: ["debris"]})
    g = _expand("driving", model)
    assets = [e.asset for e in g.paths()[0].entities]
    assert assets[:2] == ["bicycle", "sedan"]  # named, in the order the text names them
    assert _node(g, "bicycle", "entity").history[0].by == "database"


def test_a_cause_no_asset_can_play_is_unsimulatable_with_the_reason() -> None:
    speed = "black ice covers the road ahead"  # no asset is ice
    # 'speed camera' is read as the ego's own camera by its name; the judge says it takes no part
    model = ScriptedModel(causes={STOP: [speed]}, entities={speed: ["speed camera", "traffic_cone"]},
                          part_of={"traffic_cone": False, "camera": False})
    g = _expand("driving", model)
    ev = _node(g, speed)
    assert ev.status == "unsimulatable"
    why = ev.history[-1].reason
    assert "camera takes no part" in why and "traffic_cone takes no part" in why
    assert not g.paths()
    police = database_of("driving").named_assets("speed enforcement is ahead", robot="ego-vehicle")
    assert list(police) == ["police_car"]  # a speed enforcement is the police, by the database


def test_a_manipulation_cause_never_takes_the_task_object_for_its_entity() -> None:
    g = _door_cause("the cat scratches at the door to come in")
    pet = _node(g, "pet", "entity")
    assert pet.status == "accepted" and pet.history[0].by == "database"
    door = _node(g, "door", "entity")
    assert door.status == "rejected" and "own task object" in door.history[-1].reason
    (path,) = g.paths()
    assert [e.asset for e in path.entities] == ["pet"]
    # grounded, the pet is a context entity outside the door, its placement a cause state
    from regen.manipulation.grounding.ground import ground_path

    sc = ground_path(path)
    pet1 = sc.entity("pet1")
    assert pet1.properties["role"] == "context" and pet1.behavior_params["relation"] == "outside"
    assert any(s.actor == "pet1" and s.cause for s in sc.fsm.states)


def test_words_that_imply_a_spill_ground_it_beside_the_animal_named() -> None:
    g = _door_cause("the dog knocked over its water bowl by the door")
    spill = _node(g, "spill", "entity")
    assert spill.status == "accepted" and spill.history[0].by == "database"
    assert "knocked over + water" in spill.history[0].reason
    (path,) = g.paths()
    assert sorted(e.asset for e in path.entities) == ["pet", "spill"]


def test_names_overlap_the_longest_wins_and_the_robot_names_nothing() -> None:
    db = database_of("driving")
    got = lambda t: [m.asset for m in db.named_in(t, exclude="ego-vehicle")]  # noqa: E731
    assert got("a police car blocks the road") == ["police_car"]  # not a sedan ('car')
    assert got("a car cuts in front of the ego-vehicle") == ["sedan"]  # 'vehicle' of ego-vehicle: none
    assert got("pedestrians cross") == ["pedestrian_group"]  # the plural alias, as written
    assert got("the GPS signal is jammed") == ["gnss"]  # not the traffic 'signal'
    assert got("a tree fell on the road") == []
    implied = [m.asset for m in db.implied_by_states("the lights at the crossing turn red")]
    assert implied == ["traffic_light"]  # a state only a traffic light has
    assert db.implied_by_states("traffic is jammed") == []  # one word names no state-owner


def test_a_cause_naming_an_asset_by_a_close_paraphrase_grounds_it_and_says_how() -> None:
    # the real sentence-embedding model (installed with the eval extra, as setup and CI do)
    washing = "the washing is still wet"
    model = ScriptedModel(causes={DOOR: [washing]}, entities={washing: ["trash_can"]},
                          part_of={"trash_can": False})
    g = _expand("manipulation", model)
    node = _node(g, "clothes", "entity")
    assert node.status == "accepted" and node.history[0].by == "database"
    assert "close paraphrase: 'washing' ~ 'laundry'" in node.history[0].reason
    assert _node(g, "trash_can", "entity").status == "rejected"


def test_paraphrases_speak_only_where_no_name_does_and_above_the_threshold() -> None:
    from regen.embeddings import default_encoder

    enc = default_encoder()
    manip, driving = database_of("manipulation"), database_of("driving")
    para = lambda db, t, **kw: [m.asset for m in db.paraphrased_in(t, enc, exclude=["robot", "ego-vehicle"], **kw)]  # noqa: E731
    assert para(manip, "a cleaning cloth is needed") == []  # a cloth is no clothing (0.76 < 0.80)
    assert para(manip, "a cleaning cloth is needed", threshold=0.7) == ["clothes"]  # looser, it would be
    assert para(driving, "a tree blocks the road") == ["barrier"]  # 'blocks road' ~ 'road block'
    assert para(driving, "the police car blocks the road") == []  # a name speaks: it is what the car does
    assert para(driving, "the ego-vehicle brakes") == []  # the robot's own words name nothing
    # an irregular plural is a name, not a paraphrase
    assert [m.asset for m in manip.named_in("the children are watching a cartoon")] == ["child"]


def test_a_motion_named_without_its_actor_grounds_the_first_asset_that_makes_it() -> None:
    db = database_of("driving")
    robot = ["ego-vehicle", "the vehicle"]
    got = db.named_assets("wrong-way driver ahead", robot=robot)
    assert list(got) == ["sedan"] and "names a motion and no actor: wrong way" in got["sedan"]
    assert db.named_assets("the ego-vehicle turns left", robot=robot) == {}  # the robot's own motion
    assert db.implied_by_motion("a car turns left while a child runs across") == []  # two actors' motions
    wrong = "wrong-way driver ahead"
    model = ScriptedModel(causes={STOP: [wrong]}, entities={wrong: ["wrong-way driver"]})
    g = _expand("driving", model)
    sedan = _node(g, "sedan", "entity")
    assert sedan.status == "accepted" and sedan.history[0].by == "database"


def test_a_model_added_entity_of_the_same_kind_as_a_named_one_is_refused_without_asking() -> None:
    # 'the front car' is bound to a sedan; a traffic queue the model adds would be a second lead car
    lights = "the front car with broken brake lights stops"
    model = ScriptedModel(causes={STOP: [lights]}, entities={lights: ["traffic_queue", "debris"]})
    g = _expand("driving", model)
    queue = _node(g, "traffic_queue", "entity")
    assert queue.status == "rejected" and "play the same part again" in queue.history[-1].reason
    assert "vehicles" in queue.history[-1].reason
    assert [e.asset for e in g.paths()[0].entities][:1] == ["sedan"]
    assert _node(g, "debris", "entity").status == "accepted"  # another kind: judged (yes), kept


def test_a_sensor_in_a_cause_is_never_given_a_state_that_works() -> None:
    """A GPS that is 'nominal' or a camera that is 'clear' explains nothing: the property judge
    is offered only the sensor's faulty states, whatever the model would have picked."""
    gps, cam = "the GPS receiver acts up", "something is wrong with the front camera"
    model = ScriptedModel(causes={STOP: [gps, cam]}, entities={gps: ["gnss"], cam: ["camera"]},
                          choose={"gnss_signal": ["nominal"], "camera_view": ["clear"]})
    g = _expand("driving", model)
    values = {n.property: n.value for n in g.nodes.values() if n.kind == "property" and n.status == "accepted"}
    assert values["gnss_signal"] in ("noisy", "jammed")
    assert values["camera_view"] in ("glare", "occluded")


def test_a_person_named_in_words_no_asset_carries_is_played_by_a_person_on_foot() -> None:
    elderly = "an elderly man shuffles across the road"  # no alias says 'elderly' or 'man'
    model = ScriptedModel(causes={STOP: [elderly]}, entities={elderly: ["debris"]}, part_of={"debris": False})
    g = _expand("driving", model)
    man = _node(g, "adult", "entity")
    assert man.status == "accepted" and man.history[0].by == "database"
    assert "names a person" in man.history[0].reason and "'elderly'" in man.history[0].reason
    (path,) = g.paths()
    assert [e.asset for e in path.entities] == ["adult"]
    assert path.entities[0].properties.get("behavior") == ["cross_the_road"]  # 'across the road'
    assert path.entities[0].properties.get("target_speed") == ["slow"]  # 'elderly', 'shuffles'


def test_an_animal_the_database_lacks_makes_the_cause_unsimulatable_without_asking_the_model() -> None:
    deer = "a deer jumps onto the road"
    model = ScriptedModel(causes={STOP: [deer]}, entities={deer: ["debris"]})
    g = _expand("driving", model)
    ev = _node(g, deer)
    assert ev.status == "unsimulatable" and ev.history[-1].by == "database"
    assert "names an animal ('deer')" in ev.history[-1].reason and "has no animal" in ev.history[-1].reason
    assert not g.paths() and "entity_edges" not in model.kinds  # no entity was asked for
