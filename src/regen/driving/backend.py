"""The driving domain behind :class:`regen.contract.DomainBackend`.

``ground`` -> Scenario (model or rules, CP-SAT placement), ``simulate`` -> Trace (Scenic
Newtonian), ``verify`` (the shared monitor with relaxation), ``render`` (bird's-eye GIF and key
frames) and ``export`` (the .scenic program and an OpenSCENARIO replay). The pipeline
(:mod:`regen.pipeline`) calls these stages; there is no other path.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING

from regen.contract import (
    DomainBackend,
    Importer,
    PropertyChoices,
    RecordedBehavior,
    Recorder,
    ReportHints,
    SimulationOutput,
    Wording,
)
from regen.core.behavior import Behavior
from regen.core.graph import CausePath
from regen.core.scenario import Scenario
from regen.core.trace import Trace
from regen.core.verdict import Verdict
from regen.driving.assets import RESOURCE
from regen.driving.grounding.rules import ground_rule_based
from regen.driving.world.egos import EGO_TEMPLATES, match_template
from regen.driving.world.replay import ego_template
from regen.driving.world.setting import DrivingParams
from regen.errors import ConfigError, GroundingError

if TYPE_CHECKING:
    from regen.driving.testing.dataset import DrivingDatasetViews
    from regen.driving.verify.typology import DrivingTypology
    from regen.llm.client import LLM

log = logging.getLogger(__name__)


def _matched(text: str) -> str | None:
    """The ego template a behavior text names, or None."""
    try:
        return match_template(text)
    except ConfigError:
        return None


#: The ego's own cabin, occupants and lamps (its mechanics rule: a cause about them is no context)
_CABIN = (r"(?:radio|music|stereo|song|playlist|podcast|headlights?|headlamps?|high\s+beams?|interior\s+lights?|"
          r"wipers?|horn|air\s+conditioning|heater|heating|seats?|seat\s*belts?|windows?|sunroof|dashboard|"
          r"infotainment|touchscreen|cabin|cup\s+holder|passengers?)\b")


#: effects of the ego moving off or speeding up, and causes that put something in its way
_GOES = (r"\b(?:drives?\s+off|drove\s+off|driving\s+off|pulls?\s+away|pulled\s+away|pulling\s+away|"
         r"accelerat\w*|speeds?\s+up|sped\s+up|speeding\s+up|sets?\s+off|moves?\s+off|moved\s+off|"
         r"starts?\s+(?:moving|driving)|started\s+(?:moving|driving)|proceed\w*)\b")
_HAZARD = (r"\b(?:steps?|stepped|stepping|runs?|ran|running|walks?|walked|walking|darts?|darted|jumps?|jumped|"
           r"dashe?s?|dashed)\s+(?:out\s+)?(?:into|onto|in\s+front\s+of|across)\b"
           r"|\b(?:in|into)\s+(?:the|its)\s+(?:ego(?:-vehicle)?'s\s+)?path\b"
           r"|\bturn(?:s|ed|ing)?\s+(?:red|yellow|amber)\b"
           r"|\b(?:brakes?|braked|braking|stops?|stopped|halts?|halted)\s+(?:suddenly|abruptly|hard|sharply)\b")
#: effects of the ego stopping or slowing, and causes that clear its way
_WAITS = (r"\b(?:stops?|stopped|stopping|brakes?|braked|braking|halts?|halted|slows?|slowed|slowing|"
          r"reduced?\s+(?:its\s+)?speed|yields?|yielded|waits?|waited)\b")
_GO_SIGNAL = (r"\bturn(?:s|ed|ing)?\s+green\b"
              r"|\b(?:road|lane|way|path|junction|intersection|crossing|crosswalk)\s+(?:is\s+|was\s+|became\s+)?"
              r"(?:clear|cleared|free|empty|open|opened|reopened)\b")


class XoscImporter(Importer):
    """OpenSCENARIO 1.x files (:mod:`regen.driving.interop.importing`, imported when one is read)."""

    suffixes = (".xosc",)

    def read(self, path: Path) -> Scenario:
        from regen.driving.interop.importing import import_xosc

        return import_xosc(path)

    def notes(self, scenario: Scenario) -> list[str]:
        imported = scenario.behavior.params.get("imported") or {}
        return [str(n) for n in imported.get("notes", [])]


class EgoRecorder(Recorder):
    """A recorded ego trajectory (CSV): the behavior it shows, which the ego replays in every
    scenario (:mod:`regen.driving.world.replay`)."""

    options = {"map": "the generated map whose coordinates the file is in (straight, four_way, t_junction); "
                      "default: the ego's start frame"}

    def read(self, path: str | Path, *, text: str | None = None,
             options: Mapping[str, str] | None = None) -> RecordedBehavior:
        from regen.driving.world.replay import recording

        options = options or {}
        self.check_options(options)
        rec, det = recording(path, map_name=options.get("map"))
        lines = [f"detected: {det.text} (its event at {rec.event_time:.1f} s; {'; '.join(det.evidence)})",
                 f"placed: {rec.placement}"]
        if text and det.template != _matched(text):
            lines.append(f"note: the text given names another behavior than the one detected; the ego "
                         f"replays the recording and its states are those of '{det.text}'")
        params = {"ego_template": det.template, "recorded": rec.model_dump(mode="json")}
        return RecordedBehavior(text=text or det.text, params=params, lines=tuple(lines))


class DrivingBackend(DomainBackend):
    name = "driving"
    database_resource = RESOURCE
    gym_envs = {"regen/Driving-v0": "regen.driving.gym.env:DrivingEnv"}
    predicates_module = "regen.driving.verify.predicates"
    params_model = DrivingParams
    edge_examples = ("regen.driving", "data/edges_example.jsonl")
    fidelity_set = ("regen.driving", "data/fidelity.jsonl")
    wording = Wording(
        expert="driving scenarios and traffic simulation",
        situation="traffic",
        cause_rule=("Each cause must involve other road users, objects, traffic lights or the ego's "
                    "sensors/driver, not the ego-vehicle's own mechanics."),
        value_hint='relative to the ego-vehicle (lane and side), e.g. "behind the ego-vehicle in the same lane"',
        robot_names=("ego-vehicle", "ego vehicle", "ego car", "ego", "the vehicle", "the car",
                     "the self-driving car", "the autonomous vehicle", "the driver"),
        entity_examples=(
            ("a boy on a scooter darts out between parked cars", "child", "yes"),
            ("a boy on a scooter darts out between parked cars", "barrier", "no"),
            ("the truck ahead sheds part of its load", "debris", "yes"),
            ("the truck ahead sheds part of its load", "traffic_light", "no"),
        ),
        judge_examples=(
            ("the ego-vehicle swerved to the left", "a parked truck blocked its lane", "yes",
             "it must steer around the truck to pass"),
            ("the ego-vehicle swerved to the left", "a car honked on a street far away", "no",
             "a sound far away gives no reason to swerve"),
            ("the ego-vehicle accelerated", "a child ran onto the road ahead", "no",
             "a child ahead makes it brake, the opposite of accelerating"),
        ),
        # causes that restate the ego's orders, programming or mechanics (rejected after the
        # judge); its camera and GNSS are not here: glare and jamming are simulated contexts
        mechanics=(
            r"(?:\bego(?:[- ](?:vehicle|car))?|\bthe\s+(?:vehicle|car))\s+(?:is|was|gets|got|has\s+been|"
            r"had\s+been)\s+(?:\w+ly\s+|just\s+)?(?:programmed|commanded|instructed|ordered|told|asked|"
            r"scheduled|designed|configured|set|routed|planned)\s+to\b"
            # a police officer's order is a context of the road, not the ego's instructions
            r"(?![^.;]*\bby\s+(?:a|an|the)\s+(?:police|officer|traffic|flagger|road\s+worker|crossing\s+guard))",
            r"\b(?:navigation|gps|route|planner|autopilot|cruise\s+control|software|program)(?:\s+system)?\s+"
            r"(?:tells?|told|instructs?|instructed|commands?|commanded|orders?|ordered|asks?|asked)\b",
            r"\b(?:passenger|operator|dispatcher)s?\b[^.;]*\b(?:asks?|asked|tells?|told|commands?|commanded|"
            r"instructs?|instructed|orders?|ordered|requests?|requested)\b",
            r"\bprograms?\s+(?:the\s+)?ego\b",
            r"(?:\bego(?:[- ](?:vehicle|car))?'s|\bthe\s+(?:vehicle|car)'s|\bthe\s+ego's)\s+(?:own\s+)?(?:\w+\s+)?"
            r"(?:brakes?|braking\s+system|engine|motor|tires?|tyres?|wheels?|steering|transmission|gearbox|"
            r"battery|fuel|gas|accelerator|throttle|suspension|axle|software|firmware|autopilot|"
            r"programming|program|controller|planner|cruise\s+control|computer|mechanics?)\b",
            r"(?:\bego(?:[- ](?:vehicle|car))?|\bthe\s+(?:vehicle|car))\s+(?:just\s+|suddenly\s+)?"
            r"(?:breaks\s+down|broke\s+down|stalls|stalled|malfunctions?|malfunctioned|overheats?|overheated|"
            r"runs\s+out\s+of|ran\s+out\s+of|has\s+(?:a|an)\s+(?:flat|mechanical|technical|engine|brake|software)|"
            r"loses\s+(?:power|its\s+brakes)|is\s+low\s+on\s+(?:fuel|gas|battery))",
            r"(?:\bego(?:[- ](?:vehicle|car))?|\bthe\s+(?:vehicle|car))\s+(?:suffers|has|experiences|develops)\s+"
            r"(?:a|an)\s+(?:sudden\s+)?(?:brake|engine|mechanical|software|steering|technical)\s+"
            r"(?:failure|fault|malfunction|problem)\b",
            # the ego's cabin, occupants and lamps: nothing on the road that it could react to
            r"(?:\bego(?:[- ](?:vehicle|car))?'s|\bthe\s+ego's)\s+(?:own\s+)?(?:\w+\s+)?" + _CABIN,
            _CABIN + r"\s+(?:in|inside|of)\s+the\s+ego\b",
        ),
        opposites=(
            (_GOES, _HAZARD, "makes the ego-vehicle wait or brake, not drive on"),
            (_WAITS, _GO_SIGNAL, "lets the ego-vehicle drive on, not stop or slow down"),
        ),
        # the ego's own words carry no meaning when telling causes apart
        stop_words=("ego", "vehicle"),
        whatif_examples=(
            ("a truck brakes ahead", "what if the truck's brake lights did not work?",
             '[{"op": "set", "entity": "truck1", "property": "brake_lights", "value": "broken"}]'),
            ("a dog runs across the road", "what if there were no dog?", '[{"op": "remove", "entity": "dog1"}]'),
        ),
        add_example="a cyclist rides ahead",
        augment_example="a cyclist swerves into the lane ahead",
        one_part_per_category=("vehicles", "pedestrians"),
    )
    report_hints = ReportHints(animation="bird's-eye animation of the run",
                               keyframes="key frames at the start, at each stage and at the end: "
                                         "the bird's-eye view, and the ego's forward camera below it "
                                         "where the camera extra is installed (click for full size)",
                               keyframe_width=640,
                               robot="ego-vehicle", proximity=True,
                               quantities={
                                   # the placement's parameters (regen.driving.world.placement)
                                   "s": ("start position along the ego's road", "m"),
                                   "v": ("speed", "m/s"),
                                   "t": ("time it acts, from the start", "s"),
                                   "d0": ("start distance before the junction", "m"),
                                   # DrivingWorld
                                   "map": ("generated road map", ""),
                                   "ego_template": ("the ego's scripted behavior", ""),
                                   "duration": ("simulated time", "s"),
                                   "dt": ("simulation step", "s"),
                                   "seed": ("random seed", ""),
                                   "grounder": ("who grounded the scenario", ""),
                                   "model_parts": ("parts the model wrote", ""),
                                   "rule_parts": ("parts the rules wrote", ""),
                                   "llm": ("model", ""),
                                   "model_calls": ("the model's answers used", ""),
                                   "grounding_notes": ("why the rules wrote parts", ""),
                               })

    def check_behavior(self, behavior: Behavior) -> None:
        if behavior.params.get("reward"):
            raise ConfigError("--reward is for manipulation behaviors; driving behaviors take --ego "
                              f"(one of: {', '.join(EGO_TEMPLATES)})")
        ego_template(behavior.text, self.params(behavior))

    def recorder(self) -> EgoRecorder:
        """A recorded ego trajectory as the behavior (``--ego-trajectory``, ``--map``)."""
        return EgoRecorder()

    def params(self, behavior: Behavior) -> DrivingParams:
        return DrivingParams.of(behavior)

    def settings_key(self, behavior: Behavior) -> dict[str, str | None]:
        params = self.params(behavior)
        key = {"ego_template": ego_template(behavior.text, params).id}
        if params.recorded is not None:  # another recording is another behavior
            import hashlib
            import json

            key["recorded"] = hashlib.sha256(json.dumps(params.recorded.samples).encode()).hexdigest()[:16]
        return key

    def property_choices(self, asset: str, behavior: Behavior | None = None) -> PropertyChoices | None:
        """An actor's start locations and speed classes follow its behavior (motion primitive):
        only the starts the primitive supports and some map of the ego's template can host
        (no junction place for an ego that changes lanes on a straight road), and no speed for
        one that does not move; where the speed classes the solver can place depend on the start
        (a car ahead of an ego that stops is no slow one), one alternative per group of starts.
        A sensor: only its faulty states."""
        from regen.driving.grounding.rules import can_host
        from regen.driving.grounding.speeds import solvable_speeds
        from regen.driving.primitives import find, for_actor, is_state_only

        db = self.database()
        if asset in db.assets and db.assets[asset].kind == "sensor":
            # a sensor that works shows no cause: only the states with an effect on what the
            # ego perceives (a GPS 'nominal' or a camera 'clear' explains nothing)
            from regen.driving.world.sensing import EFFECTS
            faults = {p: list(EFFECTS[p]) for p in db.parameters_of(asset) if p in EFFECTS}
            return PropertyChoices.fixed(faults) if faults else None
        if asset not in db.assets or is_state_only(asset) or not db.assets[asset].behaviors:
            return None
        starts = db.property_candidates(asset, "start_location") or []
        speeds = db.property_candidates(asset, "target_speed") or []
        out: dict[str | None, dict[str, list[str]]] = {}
        specs = {b: spec for b in db.assets[asset].behaviors if (spec := find(b)) is not None}
        # properties a primitive implies (siren on): that value with it, any value without it
        implied = {p: db.property_candidates(asset, p) or [] for spec in specs.values() for p in spec.implies
                   if p in db.parameters_of(asset)}
        template = (ego_template(behavior.text, self.params(behavior))
                    if behavior is not None and behavior.domain == self.name else None)
        size = tuple(float(x) for x in db.assets[asset].size)
        for b, spec in specs.items():
            allowed: dict[str, list[str]] = {}
            here: list[str] = []
            if starts:
                here = [x for x in spec.starts if x in starts] or list(starts)
                if template is not None:
                    junction = for_actor(asset, b).needs_junction
                    here = [x for x in here if can_host(template, x, junction_primitive=junction)]
                    if not here:
                        continue  # a motion no map of the ego's behavior can host
                allowed["start_location"] = here
            if speeds and spec.moves:
                allowed["target_speed"] = list(speeds)
            for p, values in implied.items():
                allowed[p] = [spec.implies[p]] if p in spec.implies else list(values)
            by_speeds: dict[tuple[str, ...], list[str]] = {}
            if template is not None and "target_speed" in allowed:  # the pairs the solver can place
                props = tuple((p, v[0]) for p, v in allowed.items() if p in spec.implies)
                for x in here:
                    by_speeds.setdefault(solvable_speeds(template, asset, b, x, tuple(speeds), size, props),
                                         []).append(x)
            if len(by_speeds) == 1:  # one group of starts: its speeds only (a car braking ahead is no slow one)
                allowed["target_speed"] = list(next(iter(by_speeds)))
            out[b] = (allowed if len(by_speeds) < 2 else
                      [{**allowed, "start_location": xs, "target_speed": list(sp)} for sp, xs in by_speeds.items()])
        return PropertyChoices("behavior", out) if out else None

    def ground(self, path: CausePath, llm: LLM | None, *, seed: int = 0) -> Scenario:
        """Model grounding when an LLM is given (rules replace what its answers leave unusable,
        recorded in ``scenario.fallbacks``), else the rule-based grounder."""
        if path.behavior.domain != self.name:
            raise GroundingError(f"the driving backend cannot ground a {path.behavior.domain} behavior")
        from regen.driving.grounding.confounders import quiet_context, unhostable_context

        robot = (self.report_hints.robot, *self.wording.robot_names)
        path, left_out = unhostable_context(path, self.database(), robot=robot)
        path, notes = quiet_context(path, self.database(), robot=robot)
        notes = [*left_out, *notes]
        if llm is not None:
            from regen.driving.grounding.model import ground_with_model

            scenario = ground_with_model(path, llm, seed=seed)
        else:
            scenario = ground_rule_based(path, seed=seed)
        if notes:
            scenario = scenario.model_copy(update={"fallbacks": [*notes, *scenario.fallbacks]})
        return scenario

    def typology(self) -> DrivingTypology:
        """The NHTSA pre-crash typology's 37 classes and the rules that read them off a trace
        (:mod:`regen.driving.verify.typology`, ``regen eval --coverage``)."""
        from regen.driving.verify.typology import typology

        return typology()

    def dataset_views(self) -> DrivingDatasetViews:
        """Reaction states, bird's-eye and camera frames, variants simulated again (``regen dataset``)."""
        from regen.driving.testing.dataset import DrivingDatasetViews

        return DrivingDatasetViews()

    def importer(self) -> XoscImporter:
        """OpenSCENARIO files (``regen import``)."""
        return XoscImporter()

    def simulate(self, scenario: Scenario, workdir: Path) -> SimulationOutput:
        from regen.driving.simulation.scenario import simulate_scenario

        return simulate_scenario(scenario)

    def warm(self) -> float:
        """Scenic, the world model, the exports' package and the causal check's reference driver
        loaded ahead of a worker's first scenario (:mod:`regen.driving.simulation.warm`)."""
        t0 = time.perf_counter()
        from regen.driving.simulation.warm import warm

        warm()
        import regen.driving.testing.causal  # noqa: F401 (the but-for check's reference driver)

        return time.perf_counter() - t0

    def render(self, scenario: Scenario, trace: Trace, verdict: Verdict, out_dir: Path) -> dict[str, Path]:
        from regen.driving.render.scenario import render_scenario

        return render_scenario(scenario, trace, verdict, out_dir)

    def policy_harness(self):
        """A driving policy in place of the scripted ego (:mod:`regen.driving.testing.harness`)."""
        from regen.driving.testing.harness import DrivingHarness

        return DrivingHarness()

    def reference_world(self, scenario: Scenario, cause: list[str]):
        """The reference driver in the scenario's world (:mod:`regen.driving.testing.causal`)."""
        from regen.driving.testing.causal import reference_world

        return reference_world(scenario, cause)

    def config(self, scenario: Scenario) -> dict:
        from regen.driving.interop.config import paper_config

        return paper_config(scenario)

    export_options = {"ego_story": "the ego's story in scenario.xosc (False: the ego is placed, not driven, "
                                    "for a user whose own agent drives it)"}

    def export(self, scenario: Scenario, out_dir: Path, trace: Trace | None = None, *,
               ego_story: bool = True) -> dict[str, Path]:
        """The Scenic programs that run the scenario and its map beside them, and with a trace an
        OpenSCENARIO replay; ``ego_story=False`` leaves the ego's story out of it (the ego is
        placed, not driven: for a user whose own agent drives it)."""
        from regen.driving.interop.scenic import export_scenic

        files = export_scenic(scenario, Path(out_dir))
        if trace is not None:
            from regen.driving.interop.openscenario import export_openscenario

            files.update(export_openscenario(scenario, trace, out_dir, ego_story=ego_story))
        return files


__all__ = ["DrivingBackend"]
