"""The Panda's controller in real PyBullet (DIRECT): straight-line moves of the hand to a
commanded point, the fingers, and grasps that carry a body until it is let go."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("pybullet")

from regen.manipulation.simulation.arm import CONTROL_EVERY, orientation  # noqa: E402
from regen.manipulation.simulation.controller import Controller  # noqa: E402
from regen.manipulation.simulation.layout import (  # noqa: E402
    EE_LINK,
    FurniturePlacement,
    ObjectPlacement,
    SceneLayout,
)
from regen.manipulation.simulation.scene import Scene  # noqa: E402


def _gap(a, b) -> float:
    return float(np.linalg.norm(np.asarray(a) - np.asarray(b)))


def _turn(q1, q2) -> float:
    """The angle [rad] of the rotation between two orientations (quaternions)."""
    return 2 * float(np.arccos(min(1.0, abs(float(np.dot(q1, q2))))))


@pytest.mark.parametrize("goal,approach", [((0.45, 0.15, 0.35), "top"), ((0.5, -0.2, 0.25), "top"),
                                           ((0.45, 0.0, 0.55), "front")])
def test_the_hand_reaches_a_commanded_pose_within_tolerance(goal, approach) -> None:
    with Scene(SceneLayout()) as scene:
        ctl = Controller(scene)
        start = scene.ee_position()
        assert _gap(start, goal) > 0.1  # a real move, not already there
        assert ctl.move_to(goal, approach=approach, tol=0.015)
        assert _gap(scene.ee_position(), goal) < 0.015
        hand = scene.link_pose("robot", EE_LINK)[1]
        assert _turn(hand, orientation(scene.p, approach)) < 0.05  # pointing as the approach says
        assert ctl.steps > 0 and ctl.steps % CONTROL_EVERY == 0
        ctl.wait(0.5)  # and it stays there
        assert _gap(scene.ee_position(), goal) < 0.015


def test_an_unreachable_point_is_reported_not_reached() -> None:
    with Scene(SceneLayout()) as scene:
        ctl = Controller(scene)
        goal = (2.0, 0.0, 0.4)  # beyond the arm's 0.855 m reach
        assert not ctl.move_to(goal, timeout=1.0)
        assert _gap(scene.ee_position(), goal) > 0.5


def test_fingers_close_and_open_on_command() -> None:
    with Scene(SceneLayout()) as scene:
        ctl = Controller(scene)
        assert scene.arm_state()[7:] == pytest.approx([0.04, 0.04], abs=1e-3)  # the hand starts open
        ctl.set_fingers(0.0)
        ctl.wait(0.5)
        assert scene.arm_state()[7:] == pytest.approx([0.0, 0.0], abs=2e-3)
        ctl.set_fingers(0.04)
        ctl.wait(0.5)
        assert scene.arm_state()[7:] == pytest.approx([0.04, 0.04], abs=2e-3)


def test_a_grasped_body_rides_with_the_hand_and_falls_once_released() -> None:
    box = ObjectPlacement("box1", "book", 0.45, -0.2, 0.0, (0.06, 0.06, 0.06), dynamic=True)
    with Scene(SceneLayout(objects=[box])) as scene:
        ctl = Controller(scene)
        top = scene.aabb("box1").hi[2]
        ctl.ignore_contacts("box1")
        assert ctl.move_to((0.45, -0.2, top + 0.1), approach="top")
        assert ctl.move_to((0.45, -0.2, top - 0.02), tol=0.02)
        ctl.grasp_object("box1")
        assert ctl.holding == "box1"
        assert ctl.move_to((0.45, -0.2, 0.35), tol=0.03)
        assert scene.position("box1")[2] > 0.2  # lifted off the floor with the hand
        ctl.release()
        assert ctl.holding is None
        ctl.wait(1.0)
        assert scene.position("box1")[2] < 0.01  # back on the floor
        assert scene.ee_position()[2] > 0.3  # the hand stayed up


def test_a_held_drawer_handle_is_dragged_to_the_commanded_opening() -> None:
    with Scene(SceneLayout(furniture=[FurniturePlacement("drawer1", "drawer", 0.8, 0.0, 0.0)])) as scene:
        ctl = Controller(scene)
        handle = np.asarray(scene.handle_position("drawer1"))
        ctl.move_to(tuple(handle + [-0.1, 0, 0]), approach="front")  # in front of it, as scripted
        assert ctl.move_to(tuple(handle), tol=0.02)
        ctl.grasp_handle("drawer1")
        assert ctl.holding == "drawer1"
        ctl.wait(0.1)
        assert scene.joint_fraction("drawer1") == pytest.approx(0.0, abs=0.02)  # still shut
        assert ctl.follow_joint("drawer1", 0.5)
        assert scene.joint_fraction("drawer1") == pytest.approx(0.5, abs=0.05)
        ctl.release()
        ctl.wait(0.3)
        assert scene.joint_fraction("drawer1") == pytest.approx(0.5, abs=0.05)  # friction holds it
