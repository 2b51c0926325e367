"""Scripted motion-primitive sequences, one per behavior kind (the default controller)."""

from __future__ import annotations

import numpy as np

from regen.manipulation.simulation.controller import Controller
from regen.manipulation.world.tasks import BehaviorDef


def run_script(ctl: Controller, behavior: BehaviorDef, furniture: str, item: str | None) -> bool:
    """Run the behavior's primitive sequence; True when every primitive reported success."""
    if behavior.script == "articulate":
        return articulate(ctl, furniture, behavior.goal_fraction)
    if behavior.script == "press":
        return press(ctl, furniture)
    if behavior.script == "carry":
        assert behavior.item is not None
        return carry(ctl, furniture, behavior.item.goal_xy)
    assert item is not None and behavior.item is not None
    return pick_place(ctl, behavior, furniture, item)


def articulate(ctl: Controller, furniture: str, goal: float) -> bool:
    """Approach the handle, hold it, drag the joint to ``goal`` (fraction), let go."""
    s = ctl.scene
    spec = s.bodies[furniture].spec
    assert spec is not None
    approach = spec.approach
    handle = np.asarray(s.handle_position(furniture))
    back = np.array([-0.1, 0, 0]) if approach == "front" else np.array([0, 0, 0.1])
    ok = ctl.move_to(tuple(handle + back), approach=approach)
    ok = ctl.move_to(tuple(handle), tol=0.02) and ok
    ctl.grasp_handle(furniture)
    ctl.wait(0.1)
    ok = ctl.follow_joint(furniture, goal) and ok
    ctl.retreat(0.08)
    ctl.wait(0.3)
    return ok


def press(ctl: Controller, furniture: str, depth: float = 0.02) -> bool:
    """Push a switch down from above, then lift off."""
    s = ctl.scene
    top = np.asarray(s.handle_position(furniture))
    ok = ctl.move_to(tuple(top + [0, 0, 0.1]), approach="top")
    ctl.set_fingers(0.0)  # a closed hand pushes with its fingertips
    ctl.move_to(tuple(top - [0, 0, depth]), speed=0.1, timeout=2.0)
    ctl.wait(0.2)
    ok = ctl.move_to(tuple(top + [0, 0, 0.1]), timeout=2.0) and ok
    ctl.wait(0.3)
    return ok


def _grasp_point(ctl: Controller, name: str) -> np.ndarray:
    box = ctl.scene.aabb(name)
    lo, hi = np.asarray(box.lo), np.asarray(box.hi)
    return np.array([(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, hi[2] - min(0.02, (hi[2] - lo[2]) / 2)])


def pick_place(ctl: Controller, behavior: BehaviorDef, furniture: str, item: str) -> bool:
    """Pick ``item`` and put it where the behavior wants it (into or out of the furniture)."""
    s = ctl.scene
    assert behavior.item is not None
    if behavior.item.start == "cavity" and behavior.furniture == "fridge":
        # inside a fridge only a side grasp fits under the top: reach in along +x
        box = s.aabb(item)
        c = (np.asarray(box.lo) + np.asarray(box.hi)) / 2
        ok = ctl.move_to(tuple(c + [-0.15, 0, 0.01]), approach="front")
        ok = ctl.move_to(tuple(c + [0.0, 0, 0.01]), tol=0.02) and ok
        ctl.grasp_object(item)
        ok = ctl.move_to(tuple(c + [0, 0, 0.04]), tol=0.02) and ok
        ok = ctl.move_to((0.38, c[1], c[2] + 0.04), tol=0.03) and ok
        ctl.wait(0.3)
        return ok
    grip = _grasp_point(ctl, item)
    ctl.ignore_contacts(item)  # open fingers straddle the item; the constraint is the grasp
    ok = ctl.move_to((grip[0], grip[1], max(0.45, grip[2] + 0.12)), approach="top")
    ok = ctl.move_to(tuple(grip + [0, 0, 0.12]), approach="top") and ok
    ok = ctl.move_to(tuple(grip), tol=0.02) and ok
    ctl.grasp_object(item)
    ok = ctl.move_to(tuple(grip + [0, 0, 0.2]), tol=0.03) and ok
    if behavior.item.start == "floor":  # into the furniture's cavity
        cav = s.cavity(furniture)
        assert cav is not None
        # near the front of the interior: deeper in, the hand would meet the chest above it
        half = (s.aabb(item).hi[0] - s.aabb(item).lo[0]) / 2
        goal = np.array([cav.lo[0] + max(half + 0.03, 0.08), (cav.lo[1] + cav.hi[1]) / 2,
                         cav.lo[2] + (grip[2] - s.aabb(item).lo[2]) + 0.05])
    else:  # out of the cavity onto the floor beside it
        gx, gy = behavior.item.goal_xy
        goal = np.array([gx, gy, grip[2] - s.aabb(item).lo[2] + 0.02])
    ok = ctl.move_to(tuple(grip + [0, 0, 0.35]), tol=0.03) and ok  # clear of fronts
    ok = ctl.move_to((goal[0], goal[1], max(0.55, goal[2] + 0.15)), tol=0.03) and ok
    ok = ctl.move_to(tuple(goal), tol=0.02, speed=0.15) and ok
    ctl.release()
    ctl.move_to(tuple(goal + [0, 0, 0.12]), timeout=1.5)
    ctl.wait(0.4)
    return ok


def carry(ctl: Controller, bucket: str, goal_xy: tuple[float, float]) -> bool:
    """Lift a bucket by its bar, carry it to ``goal_xy`` [m] and set it down."""
    s = ctl.scene
    bar = np.asarray(s.handle_position(bucket))
    ok = ctl.move_to(tuple(bar + [0, 0, 0.1]), approach="top")
    ok = ctl.move_to(tuple(bar), tol=0.02) and ok
    ctl.grasp_object(bucket)
    ok = ctl.move_to(tuple(bar + [0, 0, 0.12]), speed=0.2) and ok
    goal = np.array([goal_xy[0], goal_xy[1], bar[2]])
    ok = ctl.move_to(tuple(goal + [0, 0, 0.12]), speed=0.2) and ok
    ok = ctl.move_to(tuple(goal + [0, 0, 0.005]), speed=0.1, tol=0.02) and ok
    ctl.release()
    ctl.move_to(tuple(goal + [0, 0, 0.12]), timeout=1.5)
    ctl.wait(0.4)
    return ok
