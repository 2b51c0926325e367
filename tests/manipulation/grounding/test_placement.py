"""CP-SAT placement: relations hold, impossible ones are reported with the reason."""

from __future__ import annotations

import pytest

from regen.manipulation.grounding.placement import Request, scene_geometry, solve_placement
from regen.manipulation.world.tasks import get_behavior

pytest.importorskip("ortools")


def _geom(behavior_id: str):
    b = get_behavior(behavior_id)
    return scene_geometry(b, f"{b.furniture}1", None)


def test_outside_the_door_is_beyond_the_wall():
    g = _geom("open_door")
    res = solve_placement([Request("pet1", "pet", (0.6, 0.25, 0.45), "outside", "door1")], g)
    assert res.status in ("optimal", "feasible")
    pet = res.placed["pet1"]
    wall_back = g.refs["door1"].hi[0]
    assert pet.x - 0.3 >= wall_back  # the whole footprint is past the wall
    assert pet.z == 0.0 and pet.support == "floor"


def test_on_table_sits_on_the_top_inside_its_footprint():
    g = _geom("turn_on_lamp")
    res = solve_placement([Request("cup1", "cup", (0.08, 0.08, 0.1), "on", "table"),
                           Request("book1", "book", (0.2, 0.15, 0.04), "on", "table")], g)
    t = g.refs["table"]
    for name, (ln, w) in (("cup1", (0.08, 0.08)), ("book1", (0.2, 0.15))):
        p = res.placed[name]
        assert p.z == pytest.approx(0.55)
        assert t.lo[0] <= p.x - ln / 2 and p.x + ln / 2 <= t.hi[0]
        assert t.lo[1] <= p.y - w / 2 and p.y + w / 2 <= t.hi[1]
    a, b = res.placed["cup1"], res.placed["book1"]
    apart_x = abs(a.x - b.x) >= (0.08 + 0.2) / 2
    apart_y = abs(a.y - b.y) >= (0.08 + 0.15) / 2
    assert apart_x or apart_y


def test_inside_a_table_is_infeasible_with_the_reason():
    g = _geom("open_cabinet")
    res = solve_placement([Request("cup1", "cup", (0.08, 0.08, 0.1), "in", "table")], g)
    assert res.status == "infeasible"
    assert "table has no interior" in res.conflicts[0]


def test_too_big_for_the_drawer_names_both_sizes():
    g = _geom("pull_drawer")
    res = solve_placement([Request("pet1", "pet", (0.6, 0.25, 0.45), "in", "drawer1")], g)
    assert res.status == "infeasible"
    assert "does not fit the interior of the drawer1" in res.conflicts[0]


def test_geometric_conflict_names_the_relations_in_the_core():
    g = _geom("open_cabinet")
    big = (0.5, 0.45, 0.3)  # only one of these fits under the table
    res = solve_placement([Request("a1", "clothes", big, "under", "table"),
                           Request("b1", "clothes", big, "under", "table")], g)
    assert res.status == "infeasible"
    assert "a1 under table" in res.conflicts[0] or "b1 under table" in res.conflicts[0]


def test_infeasible_placement_names_a_minimal_conflict_set():
    # two boxes 0.3 x 0.4 m do not both fit under the table (0.42 x 0.82 m free of the legs);
    # the four other relations are satisfiable with either box, yet CP-SAT's own core names all
    # six: the verdict must name only the two that conflict
    g = _geom("open_cabinet")
    box = (0.3, 0.4, 0.3)
    reqs = [Request("cup1", "cup", (0.08, 0.08, 0.1), "on", "table"),
            Request("a1", "box", box, "under", "table"),
            Request("pet1", "pet", (0.6, 0.25, 0.45), "near", "table"),
            Request("b1", "box", box, "under", "table"),
            Request("book1", "book", (0.2, 0.15, 0.04), "on", "table"),
            Request("trash1", "trash_can", (0.3, 0.3, 0.4), "right_of", "cabinet1")]
    res = solve_placement(reqs, g)
    assert res.status == "infeasible"
    assert res.core == ["a1 under table", "b1 under table"]
    assert res.conflicts[0].endswith(": a1 under table; b1 under table")
    named = [r for r in reqs if f"{r.name} {r.relation.replace('_', ' ')} {r.reference}" in res.core]
    assert solve_placement(named, g).status == "infeasible"  # the set alone conflicts
    for r in named:  # and it is minimal: without any one of its relations the rest is feasible
        assert solve_placement([q for q in reqs if q is not r], g).status in ("optimal", "feasible")


def test_out_of_reach_and_keepout():
    g = _geom("open_door")
    res = solve_placement([Request("child1", "child", (0.3, 0.25, 1.1), "out_of_reach", "robot")], g)
    p = res.placed["child1"]
    assert max(abs(p.x) - 0.15, abs(p.y) - 0.125) >= 0.9
    for _label, box in g.keepouts:
        inside = box.lo[0] < p.x < box.hi[0] and box.lo[1] < p.y < box.hi[1]
        assert not inside


def test_seed_changes_the_solution_but_not_the_relation():
    g = _geom("turn_on_lamp")
    sols = {(r.placed["cup1"].x, r.placed["cup1"].y) for r in
            (solve_placement([Request("cup1", "cup", (0.08, 0.08, 0.1), "on", "table")], g, seed=s)
             for s in range(4))}
    assert len(sols) > 1
