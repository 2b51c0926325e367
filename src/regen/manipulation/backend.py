"""The manipulation domain behind :class:`regen.contract.DomainBackend` (PyBullet)."""

from __future__ import annotations

from pathlib import Path

from regen.contract import DomainBackend, PropertyChoices, ReportHints, SimulationOutput, Wording
from regen.core.behavior import Behavior
from regen.core.graph import CausePath
from regen.core.scenario import Scenario
from regen.core.trace import Trace
from regen.core.verdict import Verdict
from regen.core.words import name_words
from regen.errors import ConfigError, SimulationError
from regen.manipulation.assets import RESOURCE
from regen.manipulation.world.setting import ManipulationParams
from regen.manipulation.world.tasks import BEHAVIORS, resolve


class ManipulationBackend(DomainBackend):
    """Ground with CP-SAT placement, simulate in PyBullet with the scripted controller."""

    name = "manipulation"
    database_resource = RESOURCE
    gym_envs = {"regen/Manipulation-v0": "regen.manipulation.gym.env:ManipulationEnv"}
    predicates_module = "regen.manipulation.verify.predicates"
    params_model = ManipulationParams
    edge_examples = ("regen.manipulation", "data/edges_example.jsonl")
    fidelity_set = ("regen.manipulation", "data/fidelity.jsonl")
    wording = Wording(
        expert="household robot manipulation and home environments",
        situation="home",
        # who needs it and why, with a worked example of another behavior: without one the offline
        # 1.5B model proposes the robot's own programming, and it copies an example of the same
        # behavior into every other behavior
        cause_rule=("Each cause says who in the home needs this done and why: a person (a child, a "
                    "parent, a guest, an elderly person), a pet or a plant; for example, for \"the robot "
                    "puts the cup in the sink\": \"the cup is dirty after breakfast\". Never the robot's "
                    "own command, instruction, programming, sensors or mechanics."),
        value_hint='relative to the robot, the table or furniture, e.g. "on the table left of the robot"',
        robot_names=("robot", "the robot arm", "the arm", "robot's gripper"),
        whatif_examples=(
            ("the desk lamp is left on", "what if the lamp had been switched off?",
             '[{"op": "set", "entity": "desk_lamp1", "property": "power", "value": "off"}]'),
            ("a child needs to go outside", "what if the child were not there?",
             '[{"op": "remove", "entity": "child1"}]'),
        ),
        add_example="a cat waits by the door to go out",
        augment_example="a guest is about to arrive for dinner",
        entity_examples=(
            ("a guest is coming over for tea", "adult", "yes"),
            ("a guest is coming over for tea", "trash_can", "no"),
            ("the houseplant's leaves are wilting", "plant", "yes"),
            ("the houseplant's leaves are wilting", "book", "no"),
        ),
        judge_examples=(
            ("the robot puts the cup in the sink", "the cup is dirty after breakfast", "yes",
             "a dirty cup belongs in the sink to be washed"),
            ("the robot puts the cup in the sink", "the tv is showing the news", "no",
             "the news has nothing to do with the cup"),
            ("the robot puts the cup in the sink", "the robot was told to tidy up", "no",
             "an order to the robot is not a situation in the home"),
        ),
        # causes that restate the robot's orders, programming, sensors or mechanics (rejected after
        # the judge); "the robot" is this robot, not "a robot vacuum" in the room
        mechanics=(
            r"(?:^|\bthe\s+|\bthis\s+)robot(?!\s+(?:vacuum|cleaner|mower|toy))\s+(?:is|was|gets|got|"
            r"has\s+been|had\s+been|becomes)\s+(?:\w+ly\s+|just\s+|being\s+)?(?:programmed|commanded|"
            r"instructed|ordered|told|asked|requested|scheduled|designed|configured|tasked|assigned|"
            r"triggered|prompted|activated|powered|charged|turned\s+on|switched\s+on|calibrated|updated)\b",
            r"\b(?:asks?|asked|tells?|told|commands?|commanded|instructs?|instructed|orders?|ordered|"
            r"programs?|programmed|requests?|requested)\s+(?:the\s+|this\s+)?robot\b"
            r"(?!\s+(?:vacuum|cleaner|mower|toy))",
            r"(?:^|\bthe\s+|\bthis\s+)robot\s+(?:receives|received|gets|got|follows|followed|obeys|obeyed|"
            r"executes|executed|runs|ran)\s+(?:a|an|the|its)\s+(?:\w+\s+)?(?:command|instruction|order|"
            r"request|task|program|routine|schedule)s?\b",
            r"\brobot's\s+(?:own\s+)?(?:\w+\s+)?(?:battery|batteries|charge|power|motors?|sensors?|cameras?|"
            r"grippers?|joints?|software|firmware|program|programming|controller|code|algorithm|schedule|"
            r"routine|task\s+list|timer|clock|memory|mechanics?|mechanism)\b",
            r"(?:^|\bthe\s+|\bthis\s+)robot\b.*\bits\s+(?:own\s+)?(?:\w+\s+)?(?:sensors?|cameras?|battery|"
            r"programming|program|software|firmware|schedule|routine)\b",
            r"(?:^|\bthe\s+|\bthis\s+)robot\s+(?:detects|detected|senses|sensed|measures|measured)\b",
            r"(?:^|\bthe\s+|\bthis\s+)robot\s+(?:\w+\s+)?(?:malfunctions?|malfunctioned|breaks\s+down|"
            r"broke\s+down|glitch\w*|reboots?|rebooted|crashes|crashed|overheats?|shuts\s+down|"
            r"needs\s+to\s+(?:re)?charge|is\s+(?:low\s+on|out\s+of)\s+(?:battery|power))\b",
        ),
    )
    report_hints = ReportHints(animation="PyBullet camera view of the run",
                               keyframes="frames at the start, at each stage and at the end "
                                         "(click for full size)",
                               robot="robot",
                               quantities={
                                   # placement (regen.manipulation.grounding)
                                   "x": ("position, x (the robot faces +x)", "m"),
                                   "y": ("position, y", "m"),
                                   "z": ("height of its base", "m"),
                                   "length": ("length", "m"),
                                   "width": ("width", "m"),
                                   "height": ("height", "m"),
                                   "furniture": ("furniture model", ""),
                                   "fraction": ("opening at the start (0 closed, 1 open)", ""),
                                   "dynamic": ("rides on a moving part", ""),
                                   "relation": ("where, relative to the reference", ""),
                                   "reference": ("placed relative to", ""),
                                   "support": ("stands on", ""),
                                   "power": ("power at the start", ""),
                                   # ManipulationWorld
                                   "behavior": ("the robot's task", ""),
                                   "duration": ("simulated time cap of a rollout", "s"),
                                   "seed": ("random seed", ""),
                                   "simulator": ("simulator", ""),
                               })

    def check_behavior(self, behavior: Behavior) -> None:
        if behavior.params.get("ego_template"):
            raise ConfigError("--ego is for driving behaviors; manipulation behaviors take --reward "
                              f"(one of: {', '.join(sorted(BEHAVIORS))})")
        resolve(self.params(behavior).reward, behavior.text)

    def params(self, behavior: Behavior) -> ManipulationParams:
        return ManipulationParams.of(behavior)

    def property_choices(self, asset: str, behavior: Behavior | None = None) -> PropertyChoices | None:
        """The object the task acts on starts as the task needs it: a lamp to switch on is off,
        a door to open is closed (its start fraction); the model does not choose that. A kind
        of that object (a desk lamp for the lamp) is taken for it too: the graph picks one for
        the task's words more often than not."""
        if behavior is None:
            return None
        try:
            task = resolve(self.params(behavior).reward, behavior.text)
        except ConfigError:
            return None
        if task.asset != asset and not set(name_words(task.asset)) <= set(name_words(asset)):
            return None
        db = self.database()
        fixed: dict[str, list[str]] = {}
        if "articulation" in db.parameters_of(asset):
            f = task.start_fraction
            fixed["articulation"] = ["closed" if f < 0.1 else "open" if f > 0.9 else "half_open"]
        if "power" in db.parameters_of(asset):
            fixed["power"] = ["on" if task.start_fraction > 0.5 else "off"]
        return PropertyChoices.fixed(fixed) if fixed else None

    def own_objects(self, behavior: Behavior) -> frozenset[str]:
        """The furniture the task acts on and the item it moves (a door, the cup it stores)."""
        try:
            task = resolve(self.params(behavior).reward, behavior.text)
        except ConfigError:
            return frozenset()
        return frozenset({task.asset} | ({task.item.asset} if task.item else set()))

    def settings_key(self, behavior: Behavior) -> dict[str, str | None]:
        return {"reward": resolve(self.params(behavior).reward, behavior.text).id}

    def ground(self, path: CausePath, llm, *, seed: int = 0) -> Scenario:
        from regen.manipulation.grounding.ground import ground_path

        return ground_path(path, llm, seed=seed)

    def simulate(self, scenario: Scenario, workdir: Path) -> SimulationOutput:
        from regen.manipulation.simulation.run import rollout

        if scenario.solver.status == "infeasible":
            raise SimulationError("the scenario's placement is infeasible: "
                                  + "; ".join(scenario.solver.conflicts))
        result = rollout(scenario)
        timings = dict(result.timings)
        timings["placement"] = scenario.solver.wall_time
        trace = result.trace.model_copy(update={"meta": {**result.trace.meta,
                                                         "physics_steps": result.physics_steps}})
        return SimulationOutput(trace=trace, timings=timings)

    def reference_world(self, scenario: Scenario, cause: list[str]):
        """None yet: a context causes the robot's task when its need holds before the task and
        is met only by it (the pet can leave once the door is open; the spill stays until it is
        mopped). The scene's contexts only stand in place (their one FSM state is ``placed``): no
        need of theirs is simulated, so nothing here can show that the task met it."""
        from regen.verify.causal import NotCheckable

        raise NotCheckable("the scene's contexts only stand in place (their FSM state is 'placed'): the need "
                           "the task meets (the pet leaving once the door is open, the spill gone once "
                           "mopped) is not simulated, so whether the context causes the task is not checked "
                           "by simulation")

    def write_episodes(self, run_dirs: list[Path], out: Path) -> dict:
        """The LeRobot v3 layout (:func:`regen.manipulation.export.lerobot.write_lerobot`), then
        read back by LeRobot's own loader where its environment (``.venv-lerobot``) is installed:
        the outcome under ``check`` (:func:`regen.manipulation.export.lerobot_check.check_written`;
        LeRobotCheckError when the loader fails)."""
        from regen.manipulation.export.card import add_check
        from regen.manipulation.export.lerobot import write_lerobot
        from regen.manipulation.export.lerobot_check import check_written

        written = write_lerobot(run_dirs, out)
        check = check_written(out, written)
        add_check(out, check["note"])  # the card says whether LeRobot's loader read it back
        return {**written, "check": check}

    def policy_harness(self):
        from regen.manipulation.testing.harness import ManipulationHarness

        return ManipulationHarness()

    def render(self, scenario: Scenario, trace: Trace, verdict: Verdict, out_dir: Path) -> dict[str, Path]:
        from regen.manipulation.render.view import render_run

        return render_run(scenario, trace, verdict, out_dir)
