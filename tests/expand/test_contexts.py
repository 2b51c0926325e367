"""Causes are contexts, not the robot's own mechanics; entity names the model invents are matched
to the closest asset; and the user can insist on a cause (``--cause``) or have one judged
(``--candidate``). Scripted model answers throughout (tests/support/fake_expansion_model.py)."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
from fake_expansion_model import ScriptedModel
from typer.testing import CliRunner

from regen import domains
from regen.assets.database import database_of
from regen.cli import app
from regen.contract import ROBOT_ORDERS, Wording
from regen.core.behavior import Behavior
from regen.core.graph import ScenarioGraph
from regen.errors import ConfigError
from regen.expand import Limits, expand
from regen.expand.edges import restates_mechanics
from regen.llm import LLM, registry
from regen.llm.testing import FunctionProvider

STOP = "the ego-vehicle stops abruptly while driving forward"
DOOR = "the robot opens the door"
PET = "the pet is waiting outside to come in"
CHILD = "a child runs across the road"


def _expand(domain: str, model: ScriptedModel, **kw) -> ScenarioGraph:
    text = {"driving": STOP, "manipulation": DOOR}[domain]
    behavior = Behavior(text=text, domain=domain, params={"reward": "open_door"} if domain == "manipulation" else {})
    limits = kw.pop("limits", Limits(max_depth=1, max_causes=6, max_entities=3))
    return expand(behavior, LLM(FunctionProvider(model)), limits=limits, **kw)


def _node(graph: ScenarioGraph, label: str, kind: str = "event"):
    return next(n for n in graph.nodes.values() if n.kind == kind and n.label == label)


# --- 1. contexts, not mechanics ----------------------------------------------------------------

MECHANICS = {
    "manipulation": [
        ("The robot is programmed to open doors", "the robot is programmed"),
        ("The robot is commanded to open the door by a human", "the robot is commanded"),
        ("The robot is triggered by a motion sensor", "the robot is triggered"),
        ("the robot's battery is charged", "robot's battery"),
        ("a human asks the robot to let the guest out", "asks the robot"),
        ("the robot receives a command to open the door", "the robot receives a command"),
        ("the robot's camera detects a person", "robot's camera"),
        ("the robot malfunctions", "the robot malfunctions"),
    ],
    "driving": [
        ("the ego-vehicle's brakes fail", "ego-vehicle's brakes"),
        ("the ego-vehicle is programmed to stop at every corner", "ego-vehicle is programmed to"),
        ("the ego's engine stalls", "the ego's engine"),
        ("the ego-vehicle runs out of fuel", "ego-vehicle runs out of"),
        ("the navigation system tells the ego to stop", "navigation system tells"),
        ("the ego-vehicle suffers a brake failure", "ego-vehicle suffers a brake failure"),
        # its own cabin, occupants and lamps: nothing on the road to react to
        ("the radio in the ego-vehicle plays a loud song", "radio in the ego"),
        ("the ego's passenger opens a window", "the ego's passenger"),
        ("the ego-vehicle's headlights switch on at dusk", "ego-vehicle's headlights"),
    ],
}
CONTEXTS = {
    "manipulation": ["a robot vacuum blocks the doorway", PET, "the pet is waiting outside",
                     "a guest wants to leave the room", "someone knocks at the door",
                     "the robot vacuum is scheduled to clean the hall", "the guest asks for a glass of water",
                     "the robot's path to the door is clear"],
    "driving": [CHILD, "A pedestrian steps into the road while the vehicle is moving forward.",
                "the truck's brakes fail ahead of the ego-vehicle", "the car ahead stalls at the light",
                "the ego's camera is blinded by sun glare", "the driver of the ego-vehicle is distracted",
                "a police officer signals the ego-vehicle to stop",
                "the ego-vehicle is ordered to stop by a police officer", "a tree fell in front",
                "a passenger steps out of the bus ahead", "an oncoming car has its headlights off"],
}


@pytest.mark.parametrize(("domain", "cause", "words"),
                         [(d, c, w) for d, cases in MECHANICS.items() for c, w in cases])
def test_the_domain_rule_finds_mechanics(domain: str, cause: str, words: str) -> None:
    assert restates_mechanics(domain, cause) == words


@pytest.mark.parametrize(("domain", "cause"), [(d, c) for d, cases in CONTEXTS.items() for c in cases])
def test_the_domain_rule_keeps_contexts(domain: str, cause: str) -> None:
    assert restates_mechanics(domain, cause) is None


@pytest.mark.parametrize("domain", ["manipulation", "driving"])
def test_mechanical_causes_are_rejected_after_the_judge_and_contexts_kept(domain: str) -> None:
    mechanical = [c for c, _ in MECHANICS[domain][:3]]
    contexts = {"manipulation": [PET, "a robot vacuum blocks the doorway"],
                "driving": [CHILD, "the ego's camera is blinded by sun glare"]}[domain]
    text = {"driving": STOP, "manipulation": DOOR}[domain]
    model = ScriptedModel(causes={text: [*mechanical, *contexts]},  # the judge finds them all plausible
                          entities={PET: ["pet"], CHILD: ["child"], contexts[1]: ["camera"]})
    g = _expand(domain, model)
    robot = domains.backend_class(domain).report_hints.robot
    for cause in mechanical:
        n = _node(g, cause)
        assert n.status == "rejected", cause
        judge, rule = n.history[-2:]
        assert (judge.action, judge.by, judge.reason) == ("accepted", "model", f"because {cause}")
        assert rule.action == "rejected" and rule.by == "rule" and rule.call_id is None
        assert f"restates the {robot}'s own command, programming or mechanics" in rule.reason
        assert f"('{restates_mechanics(domain, cause)}')" in rule.reason
        edge = next(e for e in g.edges if e.source == n.id)
        assert edge.status == "rejected" and edge.history[-1] == rule
        assert not any(e.target == n.id for e in g.edges)  # no entity was looked for
    for cause in contexts:
        assert _node(g, cause).status in ("accepted", "unsimulatable"), cause
    assert _node(g, contexts[0]).status == "accepted"
    assert {tuple(p.events) for p in g.paths()} >= {(contexts[0], text)}


def test_a_domain_without_its_own_list_rejects_orders_to_the_robot() -> None:
    wording = Wording(expert="warehouse logistics", situation="warehouse", cause_rule="...", value_hint="...")
    assert wording.mechanics == ROBOT_ORDERS
    domains.register("aisle", "toydomain:AisleBackend")
    try:
        assert restates_mechanics("aisle", "the robot is told to stop by the manager") == "the robot is told"
        assert restates_mechanics("aisle", "a worker steps into the aisle") is None
    finally:
        domains.unregister("aisle")


def test_a_broken_pattern_is_reported_with_its_domain() -> None:
    from toydomain import AisleBackend

    class Broken(AisleBackend):
        name = "broken"
        wording = Wording(expert="x", situation="x", cause_rule="x", value_hint="x", mechanics=("robot (",))

    domains.register("broken", Broken)
    try:
        with pytest.raises(ConfigError, match="'broken'.*not a valid regular expression"):
            restates_mechanics("broken", "anything")
    finally:
        domains.unregister("broken")


# --- 2. entity names matched to the closest asset ------------------------------------------------


@pytest.mark.parametrize(("domain", "name", "asset"), [
    ("manipulation", "watering_plant", "plant"),
    ("manipulation", "coffee cup", "cup"),
    ("manipulation", "cup of coffee", "cup"),
    ("driving", "ambulence", "ambulance"),  # a typo
    ("driving", "trafic light", "traffic_light"),
])
def test_close_names_match_an_asset(domain: str, name: str, asset: str) -> None:
    db = database_of(domain)
    assert db.resolve(name) is None
    m = db.match(name)
    assert m is not None and m.asset == asset and 0.75 <= m.similarity <= 1.0


@pytest.mark.parametrize(("domain", "name"), [
    ("driving", "tree"), ("driving", "fallen tree"), ("driving", "radio"), ("driving", "road"),
    ("manipulation", "radio"), ("manipulation", "watering can"), ("manipulation", "storage furniture"),
])
def test_unrelated_names_match_nothing(domain: str, name: str) -> None:
    db = database_of(domain)
    assert db.resolve(name) is None and db.match(name) is None


def test_descriptions_are_matched_too() -> None:
    db = database_of("manipulation")
    # today's descriptions do not call a cabinet furniture: no guess (not 'open storage box' either)
    assert db.match("storage furniture") is None
    assets = dict(db.assets)
    assets["cabinet"] = assets["cabinet"].model_copy(update={"description": "storage furniture with a hinged door"})
    richer = db.model_copy(update={"assets": assets})
    m = richer.match("storage furniture")
    assert (m.asset, m.via, m.key) == ("cabinet", "description", "storage furniture")
    assert m.describe("storage furniture") == ("matched 'storage furniture' to asset 'cabinet' (by its "
                                               "description 'storage furniture') (similarity 0.95)")


def test_entities_the_model_names_are_matched_and_the_match_recorded() -> None:
    plant = "the plant by the door needs fresh air"
    model = ScriptedModel(causes={DOOR: [plant, PET]},
                          entities={plant: ["watering_plant", "radio", "robot arm"], PET: ["dog"]},
                          values={"location": ["by the door"]}, choose={"location": ["by the door"]})
    g = _expand("manipulation", model)
    ent = _node(g, "plant", "entity")
    assert ent.status == "accepted" and ent.asset == "plant"
    (accepted,) = ent.history  # the event names the plant: the database decides, whatever the model wrote
    assert (accepted.action, accepted.by) == ("accepted", "database")
    assert accepted.reason == "the event names it (its id)"
    dog = _node(g, "pet", "entity")
    assert dog.history[0].by == "database" and dog.history[0].reason == "the event names it (its id)"
    radio = _node(g, "radio", "entity")
    assert radio.status == "rejected" and radio.history[-1].by == "database"
    assert radio.history[-1].reason == "'radio' is not in the manipulation asset database"
    arm = _node(g, "robot arm", "entity")
    assert arm.status == "rejected" and "names the robot itself" in arm.history[-1].reason
    assert {tuple(p.events) for p in g.paths()} == {(plant, DOOR), (PET, DOOR)}


def test_driving_aliases_match_and_the_papers_tree_stays_unsimulatable() -> None:
    jay, amb, tree = "a jaywalker walked in front", "a car pulls out ahead", "a tree fell in front"
    model = ScriptedModel(causes={STOP: [jay, amb, tree]},
                          entities={jay: ["pedestrian"], amb: ["car", "ego vehicle"], tree: ["tree"]})
    g = _expand("driving", model)
    # the event's own word names the asset: the database decides, whatever name the model used
    assert _node(g, "adult", "entity").history[0].reason == "the event names it (its alias 'jaywalker')"
    assert _node(g, "sedan", "entity").status == "accepted"
    ego = _node(g, "ego vehicle", "entity")  # never guessed to be a sedan
    assert ego.status == "rejected" and "names the ego-vehicle itself" in ego.history[-1].reason
    t = _node(g, tree)
    assert t.status == "unsimulatable" and "tree" in t.history[-1].reason
    assert _node(g, "tree", "entity").history[-1].reason == "'tree' is not in the driving asset database"


def test_a_state_the_events_words_name_is_the_only_choice_and_the_others_say_why() -> None:
    # the offline model chose light_state = red for "the light turns red" (a light red from the
    # start): the event's words name turns_red, so the judge is offered only that
    light = "the traffic light ahead turns red"
    model = ScriptedModel(causes={STOP: [light]}, entities={light: ["traffic_light"]},
                          choose={"light_state": ["red"]})
    g = _expand("driving", model)
    turns = _node(g, "light_state = turns_red", "property")
    assert turns.status == "accepted"
    # the light has no other property, so nothing is left to choose: no call, the database decides
    assert "properties" not in model.kinds
    assert (turns.history[-1].by, turns.history[-1].call_id) == ("database", None)
    assert turns.history[-1].reason == 'the event says "turns red", which names light_state = turns_red'
    red = _node(g, "light_state = red", "property")
    assert red.status == "rejected" and red.history[-1].by == "rule"
    assert red.history[-1].reason == 'the event says "turns red", which names light_state = turns_red'


# --- 3. the user insists: --cause; the user asks: --candidate --------------------------------------


def test_a_forced_cause_is_accepted_despite_the_judge_and_expanded() -> None:
    guest = "a guest knocks and wants to come in"
    model = ScriptedModel(causes={DOOR: ["a dragon knocks"]},
                          plausible={guest: False, "a dragon knocks": False, "a ghost opens it": False},
                          entities={guest: ["guest", "door"]}, values={"location": ["outside the door"]},
                          choose={"location": ["outside the door"], "articulation": ["closed"]})
    g = _expand("manipulation", model, forced_causes=[guest], candidates=["a ghost opens it"])
    n = _node(g, guest)
    assert n.status == "accepted"
    proposed, accepted = n.history
    assert (proposed.action, proposed.by) == ("proposed", "user")
    assert (accepted.action, accepted.by) == ("accepted", "user")
    assert accepted.reason == ("given with --cause, accepted without judging; the judge said it is "
                               f"implausible: because {guest}")
    assert accepted.call_id  # the judge's call, to audit its opinion
    edge = next(e for e in g.edges if e.source == n.id and e.target == g.root)
    assert edge.status == "accepted" and edge.history[-1] == accepted
    # then entities and properties like any other cause
    (path,) = g.paths()
    assert path.events == [guest, DOOR] and {e.asset for e in path.entities} == {"adult"}  # not its door
    assert next(e for e in path.entities if e.asset == "adult").properties["location"] == ["outside the door"]
    # a --candidate keeps its judged meaning: rejected, and kept with the judge's reason
    ghost = _node(g, "a ghost opens it")
    assert ghost.status == "rejected" and ghost.history[0].by == "user"
    assert (ghost.history[-1].by, ghost.history[-1].reason) == ("model", "because a ghost opens it")
    assert _node(g, "a dragon knocks").status == "rejected"
    # one judging question per cause: the proposal, the candidate and the forced cause
    assert model.kinds.count("judge") == 3


def test_a_forced_mechanical_cause_is_accepted_with_a_note() -> None:
    cause = "the robot is programmed to open the door at noon"
    model = ScriptedModel(causes={DOOR: []}, entities={cause: ["door"]})
    g = _expand("manipulation", model, forced_causes=[cause])
    n = _node(g, cause)
    accepted = next(d for d in n.history if d.action == "accepted")
    assert accepted.reason.endswith("a rule would have rejected it: it restates the robot's own command, "
                                    "programming or mechanics ('the robot is programmed'), not a context in "
                                    "which it acts")
    # the only entity offered is the door the robot opens: its own task, no cause's entity
    assert n.status == "unsimulatable" and "own task object" in n.history[-1].reason


def test_a_forced_cause_keeps_the_users_words_when_the_model_proposes_it_too() -> None:
    model = ScriptedModel(causes={STOP: ["A child runs across the road."]}, plausible={CHILD: False},
                          entities={CHILD: ["child"]})
    g = _expand("driving", model, forced_causes=[f"  {CHILD} "])
    causes = [n for n in g.events(None) if n.id != g.root]
    assert [n.label for n in causes] == [CHILD] and causes[0].status == "accepted"
    assert any(d.action == "merged" and "A child runs across the road" in d.reason for d in causes[0].history)


# --- CLI: regen expand and regen generate ----------------------------------------------------------

CLI = {
    # domain -> (behavior, forced cause (judged implausible), its entity, rejected candidate, expansion)
    "driving": (STOP, CHILD, "child", "a jaywalker in another city",
                dict(entities={CHILD: ["child"]},
                     choose={"behavior": ["cross_the_road"], "start_location": ["roadside_ahead"]})),
    "manipulation": (DOOR, PET, "pet", "a dragon knocks",
                     dict(entities={PET: ["pet"]}, values={"location": ["outside the door"]},
                          choose={"location": ["outside the door"]})),
}


def _model(domain: str, **kw) -> ScriptedModel:
    text, forced, _, candidate, expansion = CLI[domain]
    return ScriptedModel(causes={text: []}, plausible={forced: False, candidate: False}, **expansion, **kw)


def _plug(monkeypatch: pytest.MonkeyPatch, model) -> None:
    monkeypatch.setitem(registry._FACTORIES, "scripted", lambda name, **kw: FunctionProvider(model))


def _graph_page(path: Path) -> dict:
    """The graph data of an interactive graph page (graph.html)."""
    page = path.read_text(encoding="utf-8")
    return json.loads(re.search(r"const G = (\{.*?\});\n", page, re.S).group(1))


def _check_graph(graph: dict, domain: str) -> None:
    _, forced, asset, candidate, _ = CLI[domain]
    nodes = {n["label"]: n for n in graph["nodes"].values()}
    f = nodes[forced]
    assert f["status"] == "accepted" and f["history"][-1]["by"] == "user"
    assert "the judge said it is implausible: because " + forced in f["history"][-1]["reason"]
    assert any(n["label"] == asset and n["kind"] == "entity" and n["status"] == "accepted"
               for n in graph["nodes"].values())
    c = nodes[candidate]
    assert c["status"] == "rejected" and c["history"][0]["by"] == "user"
    assert c["history"][-1]["by"] == "model" and c["history"][-1]["reason"] == "because " + candidate


def _check_report(report: str, domain: str) -> None:
    """The report's table of cause events: the rejected --candidate with the judge's reason, the
    --cause accepted by the user with the judge's opinion."""
    import html as html_lib

    _, forced, _, candidate, _ = CLI[domain]
    rows = {html_lib.unescape(re.sub(r"<[^>]+>", "|", r)).split("|")[2]: html_lib.unescape(re.sub(r"<[^>]+>", " ", r))
            for r in re.findall(r"<tr><td>.*?</tr>", report, re.S)}
    cand = " ".join(rows[candidate].split())
    assert "--candidate rejected model because " + candidate in cand
    cause = " ".join(rows[forced].split())
    assert cause.startswith(f"{forced} --cause accepted user given with --cause") and "implausible" in cause


@pytest.mark.parametrize("domain", ["driving", "manipulation"])
def test_expand_cli_takes_cause_and_candidate(domain: str, tmp_path: Path, monkeypatch) -> None:
    text, forced, _, candidate, _ = CLI[domain]
    _plug(monkeypatch, _model(domain))
    out = tmp_path / "graph"
    res = CliRunner().invoke(app, ["expand", text, "--domain", domain, "--out", str(out), "--llm", "scripted",
                                   "--cache", str(tmp_path / "c.sqlite"), "--cause", forced,
                                   "--candidate", candidate], env={"COLUMNS": "200"})
    assert res.exit_code == 0, res.output
    assert "1 simulatable cause chain" in res.output and f"{forced} -> {text}" in res.output
    saved = json.loads((out / "graph.json").read_text())
    _check_graph({"nodes": saved["nodes"]}, domain)
    _check_graph(_graph_page(out / "graph.html"), domain)


def _generate(*args: str):
    return CliRunner().invoke(app, ["generate", *args, "--log", "quiet"], env={"COLUMNS": "200"})


def test_generate_cli_records_causes_and_resumes_only_with_the_same(tmp_path: Path, monkeypatch) -> None:
    from fake_backend import FakeBackend

    monkeypatch.setitem(domains._REGISTRY, "driving", "fake_backend:FakeBackend")
    FakeBackend.simulated = []
    _plug(monkeypatch, _model("driving"))
    _, forced, _, candidate, _ = CLI["driving"]
    run = tmp_path / "run"
    base = (STOP, "--domain", "driving", "--out", str(run), "--llm", "scripted", "-n", "1",
            "--candidate", candidate)
    res = _generate(*base, "--cause", forced)
    assert res.exit_code == 0, res.output
    settings = json.loads((run / "run.json").read_text())["settings"]
    assert settings["forced_causes"] == [forced] and settings["candidates"] == [candidate]
    _check_graph(_graph_page(run / "graph.html"), "driving")
    report = (run / "report.html").read_text()
    assert 'href="graph.html"' in report  # the report's interactive graph, with every reason
    _check_report(report, "driving")
    # another --cause changes the result: a resume is refused
    res = _generate(*base, "--cause", "a bus blocks the lane")
    assert res.exit_code == 2 and "forced_causes" in res.output and "--fresh" in res.output


@pytest.mark.slow
@pytest.mark.parametrize("domain", ["driving", "manipulation"])
def test_generate_cli_on_the_real_simulator_takes_cause_and_candidate(domain: str, tmp_path: Path,
                                                                      monkeypatch) -> None:
    pytest.importorskip({"driving": "scenic", "manipulation": "pybullet"}[domain])
    text, forced, _, candidate, _ = CLI[domain]
    _plug(monkeypatch, _model(domain, otherwise="this is not JSON"))  # grounding falls back to rules
    run = tmp_path / "run"
    res = _generate(text, "--domain", domain, "--out", str(run), "--llm", "scripted", "-n", "1",
                    "--cause", forced, "--candidate", candidate)
    assert res.exit_code == 0, res.output
    manifest = json.loads((run / "run.json").read_text())
    assert manifest["status"] == "done" and manifest["settings"]["forced_causes"] == [forced]
    (folder,) = manifest["scenarios"]
    scenario = json.loads((run / "scenarios" / folder / "scenario.json").read_text())["scenario"]
    assert scenario["causal_graph"][0] == forced  # the insisted-on cause became the scenario
    report = (run / "report.html").read_text()
    assert 'href="graph.html"' in report
    _check_report(report, domain)
    _check_graph(_graph_page(run / "graph.html"), domain)
