"""No input makes a reading path raise anything but the project's own error (Hypothesis).

The functions are the ones the commands call: ``recording`` (``generate --ego-trajectory``),
``load_cases`` and the resume of ``fidelity.jsonl`` (``eval --fidelity``), ``import_xosc``
(``regen import``: the reader, the map, the kinematic play and the ego's detection). Inputs:
random bytes; CSV from random headers and rows (byte-order marks, CRLF, NaN, huge numbers,
fields over the csv module's limit); JSON lines mixing cases, random JSON, broken and deeply
nested lines and a cut-off tail; OpenSCENARIO files from a small grammar of valid and broken
elements, attributes and values, some cut short or with bytes spliced in. A few hundred examples
in all, a few seconds; no example database is written.
"""

from __future__ import annotations

import json
import tempfile
import xml.etree.ElementTree as ET
from collections import Counter
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from regen.errors import RegenError

SETTINGS = {"deadline": None, "database": None, "derandomize": True,
            "suppress_health_check": [HealthCheck.too_slow, HealthCheck.data_too_large, HealthCheck.large_base_example]}

# --- values a file may hold where a number belongs ------------------------------------------------

NUMBERS = st.one_of(
    st.floats(-200, 200).map(lambda v: f"{v:.3f}"),
    st.integers(-10, 100).map(str),
    st.sampled_from(["nan", "inf", "-inf", "1e400", "1e308", "-1e308", "1e9", "1e-320", "0", "-0", "", " ", "abc",
                     "$p", "${1 + 2}", "1_0", "0x10", "\u0661", "1e", "\x00", "9" * 400]),
)


def _rarely(draw, one_in: int = 100) -> bool:
    """True about once in ``one_in`` draws. A middle value of the range, not an end: Hypothesis
    draws the ends of a range far more often than the rest."""
    return draw(st.integers(0, one_in - 1)) == one_in // 2


def _pick(draw, good: list, bad: list, one_in: int = 100):
    """One of ``good``; rarely one of ``bad``."""
    return draw(st.sampled_from(bad)) if bad and _rarely(draw, one_in) else draw(st.sampled_from(good))


@pytest.fixture(scope="module")
def scratch(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("reading")


def _write(data: bytes, scratch: Path, name: str = "input") -> Path:
    """``data`` as the file ``name`` in a folder of its own (a map or results file beside it is the
    example's own)."""
    f = Path(tempfile.mkdtemp(dir=scratch)) / name
    f.write_bytes(data)
    return f


def _only_regen_errors(call) -> None:
    try:
        call()
    except RegenError as exc:
        assert "\n" not in str(exc), str(exc)  # one line: the CLI prints it as it is


# --- trajectory CSV --------------------------------------------------------------------------------

COLUMNS = ["t", "x", "y", "heading", "speed", "T", " x ", "z", "", "\ufefft"]


@st.composite
def trajectory_csv(draw) -> bytes:
    head = draw(st.lists(st.sampled_from(COLUMNS), min_size=0, max_size=6))
    if draw(st.booleans()):
        head = ["t", "x", "y", *head]
    n = draw(st.integers(0, 40))
    rows = []
    if draw(st.booleans()):  # a plausible recording: increasing time, a path, some speed
        t, x, dt = 0.0, 0.0, draw(st.sampled_from([0.05, 0.1, 0.2, 1.0]))
        v = draw(st.floats(0, 30))
        a = draw(st.floats(-8, 4))
        for _ in range(n):
            row = {"t": f"{t:.3f}", "x": f"{x:.3f}", "y": "0", "heading": "0", "speed": f"{v:.3f}"}
            rows.append([row.get(c.strip().lower(), draw(NUMBERS)) for c in head])
            t, x, v = t + dt, x + v * dt, max(0.0, v + a * dt)
    else:
        rows = [[draw(NUMBERS) for _ in head] for _ in range(n)]
    twist = draw(st.sampled_from(["none", "none", "big field", "blank row", "bad byte"]))
    if twist == "big field" and rows and head:
        rows[draw(st.integers(0, len(rows) - 1))][0] = "1" * 140_000  # over the csv module's field limit
    elif twist == "blank row":
        rows.insert(draw(st.integers(0, len(rows))), [])
    end = draw(st.sampled_from(["\n", "\r\n"]))
    text = end.join(",".join(r) for r in [head, *rows]) + end
    data = text.encode("utf-8")
    if draw(st.booleans()):
        data = b"\xef\xbb\xbf" + data
    if twist == "bad byte":
        data = data.replace(b",", b"\xe9", 1)  # one byte that is not UTF-8
    return data


@settings(max_examples=120, **SETTINGS)
@given(data=st.one_of(trajectory_csv(), st.binary(max_size=300)),
       map_name=st.sampled_from([None, None, "straight", "four_way", "t_junction", "moon"]))
def test_a_trajectory_file_gives_a_recording_or_a_regen_error(scratch: Path, data: bytes,
                                                             map_name: str | None) -> None:
    from regen.driving.world.replay import recording

    f = _write(data, scratch)
    _only_regen_errors(lambda: recording(f, map_name=map_name))


# --- fidelity JSON lines ---------------------------------------------------------------------------

JSON = st.recursive(st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=10),
                    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=5), inner, max_size=3),
                    max_leaves=8)
CASE = {"id": "a", "domain": "driving", "behavior": "the ego-vehicle stops abruptly while driving forward",
        "ego_template": "stop_abruptly", "cause": "a child runs", "entities": [{"any_of": ["child"]}], "split": "test"}
RESULT = {"id": "a", "domain": "driving", "split": "test", "status": "verified", "entities_ok": True,
          "states_ok": 0, "states_total": 0, "shown": [], "folder": "", "causal": None}


@st.composite
def json_line(draw, whole: dict) -> str:
    kind = draw(st.integers(0, 5))
    if kind == 0:
        return json.dumps({**whole, "id": draw(st.text(min_size=1, max_size=8))})
    if kind == 1:  # a whole line with one field changed to anything
        key = draw(st.sampled_from(sorted(whole)))
        return json.dumps({**whole, key: draw(JSON)})
    if kind == 2:
        return json.dumps(draw(JSON))
    if kind == 3:
        return "[" * draw(st.sampled_from([2, 5000, 100_000]))
    if kind == 4:
        return json.dumps(whole)[: draw(st.integers(0, 30))]  # cut short
    return draw(st.text(max_size=20))


@st.composite
def json_lines_file(draw, whole: dict) -> bytes:
    lines = draw(st.lists(json_line(whole), max_size=5))
    data = "\n".join(lines).encode("utf-8", "surrogatepass")
    if draw(st.booleans()):
        data += b"\n"
    if _rarely(draw, 6):
        data = b"\xef\xbb\xbf" + data
    if _rarely(draw, 6):
        data += draw(st.binary(max_size=8))
    return data


@settings(max_examples=60, **SETTINGS)
@given(data=st.one_of(json_lines_file(CASE), st.binary(max_size=200)))
def test_a_labeled_set_gives_cases_or_a_regen_error(scratch: Path, data: bytes) -> None:
    from regen.evaluation.fidelity_set import load_cases

    f = _write(data, scratch)
    _only_regen_errors(lambda: load_cases(f))


@settings(max_examples=60, **SETTINGS)
@given(data=st.one_of(json_lines_file(RESULT), st.binary(max_size=200)))
def test_a_results_file_resumes_or_gives_a_regen_error(scratch: Path, data: bytes) -> None:
    from regen.evaluation.fidelity import RESULTS, evaluate_fidelity, table

    out = _write(data, scratch, RESULTS).parent
    _only_regen_errors(lambda: table(evaluate_fidelity([], out)))


# --- OpenSCENARIO from a small grammar -------------------------------------------------------------


def _el(tag: str, attrs: dict[str, str] | None = None, *children: ET.Element) -> ET.Element:
    el = ET.Element(tag, attrs or {})
    el.extend(children)
    return el


EXTREMES = st.sampled_from(["1e9", "-1e9", "0", "-0.0", "1e-9", "1e-300", "-5", "123456789.5", "7"])


@st.composite
def value(draw, good: str) -> str:
    """Mostly the good value; at times a number the reader takes but that is far from good (zero,
    negative, a billion); rarely anything a file may hold where a number belongs."""
    if _rarely(draw, 300):
        return draw(NUMBERS)
    return draw(EXTREMES) if _rarely(draw, 20) else good


@st.composite
def position(draw, x: float, y: float) -> ET.Element:
    if _rarely(draw, 300):
        return _el("Position", None, _el("LanePosition", {"roadId": "0", "laneId": "-1", "s": "5"}))
    return _el("Position", None, _el("WorldPosition", {"x": draw(value(f"{x}")), "y": draw(value(f"{y}")),
                                                      "z": "0", "h": draw(value("0.0"))}))


def _rule(draw) -> str:
    return _pick(draw, ["lessThan", "lessOrEqual", "greaterThan", "greaterOrEqual", "equalTo"], ["often"])


@st.composite
def condition(draw, entity: str) -> ET.Element:
    kind = _pick(draw, ["time", "distance", "ttc", "speed", "offset"], ["other", "two"])
    attrs = {"name": "c", "delay": draw(value("0")), "conditionEdge": _pick(draw, ["none", "rising"], ["falling"])}
    if kind == "time":
        return _el("Condition", attrs, _el("ByValueCondition", None, _el(
            "SimulationTimeCondition", {"value": draw(value("2")), "rule": _rule(draw)})))
    refs = [_el("EntityRef", {"entityRef": entity})] * (2 if kind == "two" else 1)
    if kind == "distance":
        inner = _el("DistanceCondition", {"value": draw(value("30")), "rule": _rule(draw), "freespace": "false"},
                    draw(position(-100.0, -1.75)))
    elif kind == "ttc":
        inner = _el("TimeToCollisionCondition", {"value": draw(value("3")), "rule": _rule(draw)},
                    _el("TimeToCollisionConditionTarget", None, draw(position(-100.0, -1.75))))
    elif kind == "offset":
        inner = _el("RelativeDistanceCondition", {"value": draw(value("10")), "rule": _rule(draw), "entityRef": "hero",
                                                  "relativeDistanceType": "longitudinal"})
    elif kind == "other":
        inner = _el("AccelerationCondition", {"value": "1", "rule": "lessThan"})
    else:
        inner = _el("SpeedCondition", {"value": draw(value("5")), "rule": _rule(draw)})
    return _el("Condition", attrs, _el("ByEntityCondition", None, _el(
        "TriggeringEntities", {"triggeringEntitiesRule": "any"}, *refs), _el("EntityCondition", None, inner)))


def _dynamics(draw, tag: str, value_of: str) -> ET.Element:
    return _el(tag, {"dynamicsShape": _pick(draw, ["step", "linear", "cubic", "sinusoidal"], ["wobbly"]),
                     "value": draw(value(value_of)),
                     "dynamicsDimension": _pick(draw, ["time", "distance", "rate"], ["mood"])})


def _speed(draw, target: str) -> ET.Element:
    return _el("PrivateAction", None, _el("LongitudinalAction", None, _el(
        "SpeedAction", None, _dynamics(draw, "SpeedActionDynamics", "2.0"),
        _el("SpeedActionTarget", None, _el("AbsoluteTargetSpeed", {"value": draw(value(target))})))))


@st.composite
def action(draw, actor: str) -> ET.Element:
    kind = _pick(draw, ["speed", "trajectory", "lane"], ["relative_speed", "signal", "door", "unknown"], 10)
    if kind == "speed":
        body = _speed(draw, draw(st.sampled_from(["0.0", "2.0", "8.0"])))
    elif kind == "relative_speed":
        body = _el("PrivateAction", None, _el("LongitudinalAction", None, _el("SpeedAction", None, _el(
            "SpeedActionTarget", None, _el("RelativeTargetSpeed", {"value": "1"})))))
    elif kind == "trajectory":
        n = 0 if _rarely(draw) else draw(st.integers(2, 5))
        verts = [_el("Vertex", {"time": draw(value(f"{i * 2.0}"))}, draw(position(-100.0 + i, -8.0 + 3 * i)))
                 for i in range(n)]
        trajectory = _el("Trajectory", {"name": "p", "closed": _pick(draw, ["false"], ["true"])},
                         _el("Shape", None, _el("Polyline", None, *verts)))
        timing = _el("Timing", {"domainAbsoluteRelative": _pick(draw, ["relative", "absolute"], ["sideways"]),
                                "scale": draw(value("1.0")), "offset": draw(value("0"))})
        body = _el("PrivateAction", None, _el("RoutingAction", None, _el(
            "FollowTrajectoryAction", None, _el("TrajectoryRef", None, trajectory), _el("TimeReference", None, timing),
            _el("TrajectoryFollowingMode", {"followingMode": "position"}))))
    elif kind == "lane":
        target = _el("RelativeTargetLane", {"entityRef": _pick(draw, [actor], ["hero"]), "value": draw(value("1"))})
        body = _el("PrivateAction", None, _el("LateralAction", None, _el(
            "LaneChangeAction", None, _dynamics(draw, "LaneChangeActionDynamics", "3.0"),
            _el("LaneChangeTarget", None, target))))
    elif kind == "signal":
        body = _el("GlobalAction", None, _el("InfrastructureAction", None, _el("TrafficSignalAction", None, _el(
            "TrafficSignalStateAction", {"name": _pick(draw, ["9001"], ["", "x"], 3), "state": "red"}))))
    elif kind == "door":
        cmd = _el("CustomCommandAction", {"type": _pick(draw, ["regen:door"], ["other"], 3)})
        cmd.text = _pick(draw, [f"{actor}=open"], [actor, "=", ""], 3)
        body = _el("UserDefinedAction", None, cmd)
    else:
        body = _el("PrivateAction", None, _el("VisibilityAction", {"graphics": "true"}))
    return _el("Action", {"name": "a"}, body)


def _event(draw, name: str, actions: list[ET.Element], conditions: list[ET.Element]) -> ET.Element:
    return _el("Event", {"name": name, "priority": "override",
                         "maximumExecutionCount": _pick(draw, ["1"], ["2"])},
               *actions, _el("StartTrigger", None, _el("ConditionGroup", None, *conditions)))


def _entity(name: str, kind: str) -> ET.Element:
    box = _el("BoundingBox", None, _el("Center", {"x": "0", "y": "0", "z": "0.5"}),
              _el("Dimensions", {"width": "1.8", "length": "4.5", "height": "1.5"}))
    body = {"car": lambda: _el("Vehicle", {"name": name, "vehicleCategory": "car"}, box),
            "walker": lambda: _el("Pedestrian", {"name": name, "pedestrianCategory": "pedestrian", "mass": "70"}, box),
            "cone": lambda: _el("MiscObject", {"name": name, "miscObjectCategory": "obstacle"}, box),
            "catalog": lambda: _el("CatalogReference", {"catalogName": "c", "entryName": "e"})}[kind]()
    return _el("ScenarioObject", {"name": name}, body)


@st.composite
def scenario(draw) -> bytes:
    """An OpenSCENARIO file: the ego 'hero' driving at 10 m/s and braking on a condition (so the
    import has a behavior to detect), others that walk, drive or stand with events of their own;
    rarely a broken element, attribute or value anywhere, or the file cut short or spliced."""
    others = [_pick(draw, ["walker", "car", "cone"], ["catalog"]) for _ in range(draw(st.integers(0, 2)))]
    names = ["hero", *(f"{k}{i}" for i, k in enumerate(others))]
    params = _el("ParameterDeclarations")
    if _rarely(draw):
        params.append(_el("ParameterDeclaration", {"name": "p", "parameterType": "double", "value": "1"}))
    root = _el("OpenSCENARIO", None,
               _el("FileHeader", {"revMajor": _pick(draw, ["1"], ["2"]), "revMinor": "2", "description": "p",
                                  "author": "h"}),
               params,
               _el("RoadNetwork", None, _el("LogicFile", {"filepath": _pick(
                   draw, ["straight.xodr"], ["four_way.xodr", "nope.xodr", "$map", "/proc/self/mem", ".", ""], 20)})),
               _el("Entities", None, _entity("hero", "car"),
                   *[_entity(n, k) for n, k in zip(names[1:], others, strict=True)]))
    privates = []
    for n, y in zip(names, [-1.75, -8.0, 1.75], strict=False):
        acts = [] if _rarely(draw) else [
            _el("PrivateAction", None, _el("TeleportAction", None, draw(position(-150.0 if n == "hero" else -100.0, y))))]
        acts.append(_speed(draw, "10.0" if n == "hero" else draw(st.sampled_from(["0.0", "1.5", "8.0"]))))
        privates.append(_el("Private", {"entityRef": n}, *acts))
    extra = _el(draw(st.sampled_from(["Foo", "EnvironmentAction"])))
    groups = []
    for n in names:
        events = [_event(draw, f"e{n}{k}", draw(st.lists(action(n), min_size=1, max_size=2)),
                         draw(st.lists(condition("hero"), max_size=2))) for k in range(draw(st.integers(0, 2)))]
        if n == "hero":
            events.insert(0, _event(draw, "brake", [_el("Action", {"name": "b"}, _speed(draw, "0.0"))],
                                    [draw(condition("hero"))]))
        actors = [_el("EntityRef", {"entityRef": n})] * _pick(draw, [1], [0, 2])
        groups.append(_el("ManeuverGroup", {"name": f"g{n}", "maximumExecutionCount": "1"},
                          _el("Actors", {"selectTriggeringEntities": "false"}, *actors),
                          _el("Maneuver", {"name": "m"}, *events)))
    stop = _el("StopTrigger", None, _el("ConditionGroup", None, _el("Condition", {"name": "end"}, _el(
        "ByValueCondition", None, _el("SimulationTimeCondition", {"value": draw(value("12")), "rule": "greaterThan"})))))
    root.append(_el("Storyboard", None,
                    _el("Init", None, _el("Actions", None, *privates, *([extra] if _rarely(draw) else []))),
                    _el("Story", {"name": "s"}, *([_el("Bar")] if _rarely(draw) else []),
                        _el("Act", {"name": "act"}, *groups)),
                    stop))
    data = ET.tostring(root, encoding="utf-8")
    if _rarely(draw, 15):
        data = data[: draw(st.integers(0, len(data)))]
    elif _rarely(draw, 15):
        at = draw(st.integers(0, len(data)))
        data = data[:at] + draw(st.binary(min_size=1, max_size=6)) + data[at:]
    return data


def test_an_openscenario_file_imports_or_gives_a_regen_error(scratch: Path) -> None:
    from regen.driving.interop.importing import import_xosc
    from regen.driving.interop.xosc_read import read_xosc

    reached: Counter[str] = Counter()

    @settings(max_examples=200, **SETTINGS)
    @given(data=st.one_of(scenario(), scenario(), st.binary(max_size=200)))
    def imports(data: bytes) -> None:
        f = _write(data, scratch, "scenario.xosc")
        try:
            read_xosc(f)
            reached["read"] += 1
            import_xosc(f)
            reached["imported"] += 1
        except RegenError as exc:
            assert "\n" not in str(exc), str(exc)

    imports()
    # the grammar's good values make files the reader reads and the player plays through, so
    # the property holds past the first error too
    assert reached["read"] >= 20 and reached["imported"] >= 5, reached
