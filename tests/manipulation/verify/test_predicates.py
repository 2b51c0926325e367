"""Manipulation predicates on hand-built traces."""

from __future__ import annotations

import numpy as np

from regen.core.trace import ActorTrack, Trace
from regen.verify import get_predicate


def _trace() -> Trace:
    n = 3
    return Trace(dt=0.1, times=[0.0, 0.1, 0.2], actors={
        "robot": ActorTrack(asset="panda", kind="robot", x=[0.0] * n, y=[0.0] * n, z=[0.0] * n,
                            states={"ee_x": [0.5, 0.5, 0.5], "ee_y": [0.0] * n, "ee_z": [0.8] * n,
                                    "holding": ["", "cup1", "cup1"]}),
        "table": ActorTrack(asset="table", kind="object", length=0.5, width=0.9, height=0.55,
                            x=[0.1] * n, y=[0.85] * n, z=[0.275] * n, states={"top": [0.55] * n}),
        "cup1": ActorTrack(asset="cup", kind="object", length=0.08, width=0.08, height=0.1,
                           x=[0.1, 0.1, 0.6], y=[0.85, 0.85, 0.0], z=[0.6, 0.7, 0.05]),
        "door1": ActorTrack(asset="door", kind="object", length=0.06, width=2.4, height=1.5,
                            x=[0.62] * n, y=[0.0] * n, z=[0.75] * n,
                            states={"joint_fraction": [0.0, 0.2, 0.5], "handle_x": [0.5] * n,
                                    "handle_y": [0.0] * n, "handle_z": [0.8] * n}),
        "pet1": ActorTrack(asset="pet", kind="object", length=0.6, width=0.25, height=0.45,
                           x=[1.3] * n, y=[0.1] * n, z=[0.225] * n),
    })


def _eval(name, args, **params):
    spec = get_predicate(name, "manipulation")
    return list(np.asarray(spec.fn(_trace(), args, {**spec.params, **params})))


def test_on_and_joint_and_holding():
    assert _eval("on", ["cup1", "table"]) == [True, False, False]
    assert _eval("joint_open", ["door1"], at_least=0.35) == [False, False, True]
    assert _eval("joint_closed", ["door1"], at_most=0.1) == [True, False, False]
    assert _eval("holding", ["robot", "cup1"]) == [False, True, True]
    assert _eval("ee_near", ["robot", "door1"], distance=0.05) == [True, True, True]


def test_outside_and_reach_and_moved():
    assert all(_eval("outside", ["pet1", "door1"]))
    assert not any(_eval("outside", ["cup1", "door1"]))
    assert all(_eval("out_of_reach", ["pet1", "robot"]))
    assert _eval("moved", ["cup1"], distance=0.3) == [False, False, True]
    assert _eval("left_of", ["cup1", "door1"]) == [False, False, False]
