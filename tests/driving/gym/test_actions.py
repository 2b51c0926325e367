"""regen/Driving-v0 actions: anything but two finite numbers is the ValueError the env documents
(never numpy's OverflowError or TypeError), before the simulator sees it."""

from __future__ import annotations

import numpy as np
import pytest

from regen.driving.gym.observation import decode_action

BAD = [[10**400, 0.0], ["brake", 0.0], "brake", "1.0 0.0", None, object(), {"a": 1}, [1.0, None],
       [[1.0, 2.0], [3.0]], [float("nan"), 0.0], [0.0, float("inf")], [1.0], [1.0, 2.0, 3.0],
       [1 + 2j, 0.0], np.array(["1", "2"])]


@pytest.mark.parametrize("action", BAD, ids=[repr(a)[:30] for a in BAD])
@pytest.mark.parametrize("normalized", [False, True])
def test_bad_actions_are_value_errors(action, normalized: bool) -> None:
    with pytest.raises(ValueError, match=r"2 finite numbers"):
        decode_action(action, normalized)


def test_good_actions_of_any_numeric_type_are_taken() -> None:
    for action in ([1, 0], (0.5, 0.01), np.array([1.0, 0.0], dtype=np.float32), np.array([[2, 0]]),
                   [10**18, 0]):  # a big int that is still a float is clipped like any other
        got = decode_action(action)
        assert np.isfinite(got.acceleration) and np.isfinite(got.curvature)
