"""What the model answers when it grounds a manipulation path, and the rules that stand in for
an unusable answer.

The model writes a narrative and chooses, per context object, one relation from
:data:`regen.manipulation.grounding.placement.RELATIONS` to a scene reference
(:class:`GroundAnswer`). Its answer is data: names are checked against the scene, and anything
missing or invalid falls back to the documented rules (:data:`RULES`), each fallback said in
the list the caller passes (``scenario.fallbacks``). Only a bad answer falls back: a model that
cannot be asked is an error for the caller.
"""

from __future__ import annotations

from pydantic import Field

from regen.core.base import Answer
from regen.core.graph import CausePath
from regen.errors import MalformedAnswerError
from regen.manipulation.assets import database as manipulation_database
from regen.manipulation.grounding.placement import (
    RELATIONS,
    Request,
    SceneGeometry,
    describe_geometry,
    structural_problems,
)
from regen.manipulation.world.tasks import BehaviorDef
from regen.templates import environment

#: a context object: (entity name, asset id, size [m])
ContextObject = tuple[str, str, tuple[float, float, float]]


class PlacementChoice(Answer):
    object: str = Field(description="name of the object to place")
    relation: str = Field(description="one relation from the list")
    reference: str = Field(description="robot, table or the furniture's name")


class GroundAnswer(Answer):
    narrative: str = Field(description="one or two sentences: why the robot does this")
    placements: list[PlacementChoice] = Field(default_factory=list)


# Rule-based placement: (behavior id or '*', asset) -> (relation, reference), where 'F' is the
# behavior's furniture. Used when the model gives no usable choice for an object.
RULES: dict[tuple[str, str], tuple[str, str]] = {
    ("open_door", "pet"): ("outside", "F"), ("open_door", "adult"): ("outside", "F"),
    ("open_door", "child"): ("outside", "F"), ("close_window", "pet"): ("near", "F"),
    ("close_window", "plant"): ("on", "table"), ("adjust_faucet", "dishes"): ("in", "F"),
    ("adjust_faucet", "cup"): ("in", "F"), ("adjust_faucet", "fruit"): ("in", "F"),
    ("adjust_faucet", "plant"): ("near", "F"), ("turn_oven_knob", "frozen_vegetables"): ("on", "F"),
    ("turn_oven_knob", "dishes"): ("on", "F"), ("pull_drawer", "clothes"): ("in", "F"),
    ("pull_drawer", "book"): ("in", "F"), ("open_cabinet", "cup"): ("in", "F"),
    ("open_cabinet", "dishes"): ("in", "F"), ("open_cabinet", "bottle"): ("in", "F"),
    ("tilt_display", "adult"): ("near", "table"), ("tilt_display", "laptop"): ("on", "table"),
    ("*", "trash_can"): ("right_of", "F"), ("*", "adult"): ("near", "table"),
    ("*", "child"): ("near", "table"), ("*", "pet"): ("left_of", "F"),
    ("*", "plant"): ("near", "table"), ("*", "tv"): ("on", "table"),
    ("open_door", "visitor"): ("outside", "F"), ("*", "visitor"): ("near", "table"),
    ("*", "spill"): ("near", "F"), ("*", "mop"): ("left_of", "F"),
    # the carried bucket leaves its place: what it is carried for stays by the table
    ("carry_bucket", "spill"): ("near", "table"), ("carry_bucket", "mop"): ("near", "table"),
    ("*", "ingredients"): ("on", "table"),
}


def rule_choice(behavior: BehaviorDef, asset: str, size: tuple[float, float, float]) -> tuple[str, str]:
    """The documented default relation of an asset in a behavior's scene."""
    for key in ((behavior.id, asset), ("*", asset)):
        if key in RULES:
            return RULES[key]
    if max(size[:2]) <= 0.35 and size[2] <= 0.45:
        return ("on", "table")
    return ("near", "table")


def reference_name(ref: str, furniture_name: str) -> str:
    """The scene's name of a reference: ``F`` (the behavior's furniture) becomes its entity name."""
    return furniture_name if ref == "F" else ref


def ask(llm: object, path: CausePath, behavior: BehaviorDef, geometry: SceneGeometry,
        context: list[ContextObject]) -> GroundAnswer:
    """The model's answer for the path's context objects (prompt ``prompts/ground.j2``)."""
    db = manipulation_database()
    prompt = environment("regen.manipulation.grounding").get_template("ground.j2").render(
        behavior=path.behavior.text, events=path.events, references=describe_geometry(geometry),
        objects=[{"name": n, "description": db.assets[a].description, "size": s}
                 for n, a, s in context],
        relations=RELATIONS, reference_names=list(geometry.refs))
    return llm.structured(prompt, GroundAnswer, purpose="ground")  # type: ignore[attr-defined]


def choose_relations(llm: object | None, path: CausePath, behavior: BehaviorDef, geometry: SceneGeometry,
                     context: list[ContextObject], fname: str, *,
                     choices: dict[str, tuple[str, str]] | None, relax: bool,
                     fallbacks: list[str]) -> tuple[str, dict[str, tuple[str, str]]]:
    """(the model's narrative or '', {object: (relation, reference)}): the model's choices,
    validated, then ``choices`` (they override) and the rules for the rest. What the rules
    wrote because the answer was unusable is appended to ``fallbacks``."""
    narrative = ""
    chosen: dict[str, tuple[str, str]] = {}
    if llm is not None and context:
        narrative = _model_choices(llm, path, behavior, geometry, context, fname, choices, relax,
                                   fallbacks, chosen)
    for name, asset, size in context:
        if choices and name in choices:
            chosen[name] = (choices[name][0], reference_name(choices[name][1], fname))
        elif name not in chosen:
            rel, ref = rule_choice(behavior, asset, size)
            chosen[name] = (rel, reference_name(ref, fname))
    return narrative, chosen


def _model_choices(llm: object, path: CausePath, behavior: BehaviorDef, geometry: SceneGeometry,
                   context: list[ContextObject], fname: str, choices: dict[str, tuple[str, str]] | None,
                   relax: bool, fallbacks: list[str], chosen: dict[str, tuple[str, str]]) -> str:
    """Ask the model; its usable choices go into ``chosen``; returns its narrative ('' if none)."""
    sizes = {n: s for n, _, s in context}
    answered: set[str] = set()  # objects the model gave any choice for
    try:
        answer: GroundAnswer | None = ask(llm, path, behavior, geometry, context)
    except MalformedAnswerError as exc:
        # only a bad answer falls back; a model that cannot be asked is the caller's error
        answer = None
        fallbacks.append(f"model answer unusable ({exc}); used the rules")
    if answer is None:
        return ""
    narrative = " ".join(answer.narrative.split())[:600]
    if not narrative:
        fallbacks.append("model narrative empty; used the rule narrative")
    for pc in answer.placements:
        answered.add(pc.object)
        ref = reference_name(pc.reference.strip(), fname)
        if pc.object in sizes and pc.relation in RELATIONS and ref in geometry.refs:
            req = Request(pc.object, "", sizes[pc.object], pc.relation, ref)
            problems = structural_problems(req, geometry.refs)
            if problems and relax:
                fallbacks.append(f"model choice rejected: {problems[0]}")
                continue
            chosen.setdefault(pc.object, (pc.relation, ref))
        else:
            fallbacks.append(f"model choice ignored: {pc.object} {pc.relation} {pc.reference}")
    missing = [n for n in sizes if n not in answered and not (choices and n in choices)]
    if missing:
        fallbacks.append(f"model gave no placement for {', '.join(missing)}; used the rules")
    return narrative


__all__ = ["RULES", "ContextObject", "GroundAnswer", "PlacementChoice", "ask", "choose_relations",
           "reference_name", "rule_choice"]
