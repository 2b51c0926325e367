"""The NHTSA pre-crash typology (Najm, Smith, Yanagisawa 2007, DOT HS 810 767: 37 pre-crash
scenarios) over simulated driving scenarios: one small rule per class, reading the trace.

The classes (number, official name, one-line description, the cause texts that present them and
the ego templates those fit) are data, ``data/typology.json``. A scenario "covers" a class when
its trace shows the class's pre-crash configuration; nothing has to crash. Every rule is a
function, named as its class's id, of the :class:`~regen.driving.verify.typology_scene.Scene`
(the ego and the other actors' tracks, the junction) that returns what shows the class, one line
per actor or event, or nothing; a scenario may show several classes, or none. The rules live in
:mod:`~regen.driving.verify.typology_junctions` (5, 6, 28-32) and
:mod:`~regen.driving.verify.typology_roads` (the others); they and their thresholds are written
out for users in docs/coverage.md.

Classes 1-4 and 35 (no driver, vehicle failure, loss of control, non-collision incidents) have
no rule: the simulator models nothing a trace could show them by.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from functools import cache
from importlib import resources

from regen.contract import Typology, TypologyCause, TypologyClass
from regen.core.behavior import Behavior
from regen.core.scenario import Scenario
from regen.core.trace import Trace
from regen.driving.verify import typology_junctions as junctions
from regen.driving.verify import typology_roads as roads
from regen.driving.verify.typology_scene import Scene, scene_of
from regen.errors import ConfigError

DATA = ("regen.driving", "data/typology.json")

Rule = Callable[[Scene], list[str]]

#: class id -> its rule; classes 1-4 and 35 have none (nothing in a trace shows them)
RULES: dict[str, Rule] = {f.__name__: f for f in (*junctions.RULES, *roads.RULES)}


# -- the typology ---------------------------------------------------------------------------------


@cache
def load_classes() -> tuple[str, str, tuple[TypologyClass, ...]]:
    """(name, source, classes) of ``data/typology.json``."""
    package, resource = DATA
    raw = json.loads((resources.files(package) / resource).read_text(encoding="utf-8"))
    classes = tuple(TypologyClass(
        id=c["id"], number=int(c["number"]), name=c["name"], description=c["description"],
        simulable=bool(c.get("simulable", True)), note=c.get("note", ""),
        causes=tuple(TypologyCause(x["text"], tuple(x.get("fits", ()))) for x in c.get("causes", ())))
        for c in raw["classes"])
    return raw["name"], raw.get("source", ""), classes


class DrivingTypology(Typology):
    """NHTSA's 37 pre-crash scenarios over driving scenarios (the module's rules)."""

    def __init__(self) -> None:
        name, source, classes = load_classes()
        super().__init__(name, classes, source)

    def explain(self, scenario: Scenario, trace: Trace) -> dict[str, list[str]]:
        scene = scene_of(scenario, trace)
        if scene is None:
            return {}
        found = {}
        for c in self.classes:
            rule = RULES.get(c.id)
            lines = rule(scene) if rule is not None else []
            if lines:
                found[c.id] = lines
        return found

    def behavior_key(self, behavior: Behavior) -> str | None:
        """The ego template of the behavior (``stop_abruptly``, ``change_lane``, ...)."""
        from regen.driving.world.replay import ego_template
        from regen.driving.world.setting import DrivingParams

        try:
            return ego_template(behavior.text, DrivingParams.of(behavior)).id
        except ConfigError:
            return None


@cache
def typology() -> DrivingTypology:
    """The driving typology, loaded once."""
    return DrivingTypology()


__all__ = ["DATA", "RULES", "DrivingTypology", "Rule", "load_classes", "typology"]
