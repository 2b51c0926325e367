"""The robot behaviors ReGen reuses: reward function, success condition and scripted controller.

A behavior is what the robot already knows how to do (RoboGen-style reward functions such as
"open the door"). ReGen never changes it; it changes the context around it. Each entry names
the furniture it acts on and where that furniture stands relative to the robot, the predicates
that say it succeeded (these close the scenario's FSM), a dense reward in the spirit of
RoboGen's (used by the optional SAC controller) and a scripted motion-primitive sequence (the
default controller).

Text to behavior: :func:`match_behavior` picks the behavior whose keywords best cover the text
(e.g. "the robot opens the door" -> ``open_door``); ties and misses raise a ConfigError that
lists the behaviors.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from regen.core.scenario import PredicateCall
from regen.errors import ConfigError

Obs = dict[str, np.ndarray | float | bool]
Reward = Callable[[Obs], float]


@dataclass(frozen=True)
class ItemSpec:
    """The object a pick-and-place behavior moves (a task object, not context)."""

    asset: str  # default asset id
    size: tuple[float, float, float]  # [m]
    start: str  # 'cavity' (inside the furniture) or 'floor'
    start_xy: tuple[float, float] = (0.0, 0.0)  # [m] world position when start == 'floor'
    goal_xy: tuple[float, float] = (0.0, 0.0)  # [m] where it is put down (floor) when leaving


@dataclass(frozen=True)
class BehaviorDef:
    id: str
    text: str  # canonical text
    keywords: tuple[str, ...]  # lower-case words/phrases that point to this behavior
    furniture: str  # furniture kind (regen.manipulation.world.furniture.FURNITURE)
    asset: str  # asset database id of the furniture entity
    pose: tuple[float, float]  # furniture origin in the world [m]; robot base at (0, 0)
    start_fraction: float  # initial joint opening (0 closed .. 1 open)
    script: str  # 'articulate', 'press', 'pick_place', 'carry'
    goal_fraction: float = 0.0  # where the script drives the joint
    success: tuple[PredicateCall, ...] = ()  # args use 'robot', 'F' (furniture), 'I' (item)
    item: ItemSpec | None = None
    reward: Reward = field(default=lambda obs: 0.0, compare=False)
    state_name: str | None = None  # what the joint means (power, water flow, heat)


# --- rewards (RoboGen style: reach the handle, then move the joint / the item) ----------------


def _dist(a: np.ndarray | float | bool, b: np.ndarray | float | bool) -> float:
    return float(np.linalg.norm(np.asarray(a, dtype=float) - np.asarray(b, dtype=float)))


def articulation_reward(goal: float) -> Reward:
    """-distance(hand, handle) - 2 |fraction - goal|: reach, then move the joint to ``goal``."""

    def reward(obs: Obs) -> float:
        return -_dist(obs["ee"], obs["handle"]) - 2.0 * abs(float(obs["fraction"]) - goal)

    return reward


def press_reward(obs: Obs) -> float:
    """Reach the switch and push it in: -distance(hand, switch) + 2 fraction."""
    return -_dist(obs["ee"], obs["handle"]) + 2.0 * float(obs["fraction"])


def transport_reward(obs: Obs) -> float:
    """Reach the item, then bring it to the goal: -d(hand, item) - 2 d(item, goal)."""
    return -_dist(obs["ee"], obs["item"]) - 2.0 * _dist(obs["item"], obs["goal"])


def _calls(*spec: tuple[str, list[str], dict] | tuple[str, list[str], dict, bool]) -> tuple[PredicateCall, ...]:
    out = []
    for s in spec:
        out.append(PredicateCall(name=s[0], args=s[1], params=s[2], negate=bool(s[3]) if len(s) > 3 else False))
    return tuple(out)


def _opened(at_least: float) -> tuple[PredicateCall, ...]:
    return _calls(("joint_open", ["F"], {"at_least": at_least}))


BEHAVIORS: dict[str, BehaviorDef] = {b.id: b for b in [
    BehaviorDef("open_door", "the robot opens the door", ("open the door", "opens the door", "door"),
                "door", "door", (0.62, 0.0), 0.0, "articulate", 0.45, _opened(0.35),
                reward=articulation_reward(0.45)),
    BehaviorDef("close_window", "the robot closes the window",
                ("close the window", "closes the window", "window"),
                "window", "window", (0.6, 0.0), 0.5, "articulate", 0.0,
                _calls(("joint_closed", ["F"], {"at_most": 0.08})), reward=articulation_reward(0.0)),
    BehaviorDef("adjust_faucet", "the robot turns the faucet handle to adjust the water flow",
                ("faucet", "water flow", "tap", "sink"),
                "faucet", "faucet", (0.6, -0.1), 0.0, "articulate", 0.85, _opened(0.6),
                reward=articulation_reward(0.85), state_name="water"),
    BehaviorDef("turn_oven_knob", "the robot turns the oven knob",
                ("oven", "knob", "stove"), "oven", "oven", (0.62, 0.1), 0.0, "articulate", 0.85,
                _opened(0.6), reward=articulation_reward(0.85), state_name="power"),
    BehaviorDef("open_cabinet", "the robot opens the cabinet door",
                ("cabinet", "cupboard"), "cabinet", "cabinet", (0.75, 0.0), 0.0, "articulate",
                0.45, _opened(0.3), reward=articulation_reward(0.45)),
    BehaviorDef("pull_drawer", "the robot pulls the drawer out", ("drawer", "pull out"),
                "drawer", "drawer", (0.8, 0.0), 0.0, "articulate", 0.75, _opened(0.5),
                reward=articulation_reward(0.75)),
    BehaviorDef("tilt_display", "the robot tilts the display", ("tilt", "display", "monitor", "screen"),
                "display", "tv", (0.5, 0.0), 0.0, "articulate", 0.85, _opened(0.6),
                reward=articulation_reward(0.85)),
    BehaviorDef("turn_on_lamp", "the robot turns on the lamp", ("lamp", "light", "switch"),
                "lamp", "lamp", (0.5, 0.12), 0.0, "press", 1.0, _opened(0.6),
                reward=press_reward, state_name="power"),
    BehaviorDef("store_item", "the robot stores an item in the drawer",
                ("store", "put away", "stores", "storage"), "drawer", "drawer", (0.8, 0.0), 0.8,
                "pick_place", 0.8, _calls(("inside", ["I", "F"], {})),
                item=ItemSpec("book", (0.16, 0.1, 0.04), "floor", start_xy=(0.3, -0.42)),
                reward=transport_reward),
    BehaviorDef("retrieve_from_fridge", "the robot retrieves an item from the fridge",
                ("fridge", "refrigerator"), "fridge", "fridge", (0.8, 0.15), 0.85, "pick_place",
                0.85, _calls(("inside", ["I", "F"], {}, True), ("holding", ["robot", "I"], {})),
                item=ItemSpec("bottle", (0.06, 0.06, 0.16), "cavity", goal_xy=(0.4, 0.1)),
                reward=transport_reward),
    BehaviorDef("retrieve_from_box", "the robot retrieves an item from the box",
                ("box",), "open_box", "open_box", (0.55, -0.25), 0.0, "pick_place", 0.0,
                _calls(("inside", ["I", "F"], {}, True), ("moved", ["I"], {"distance": 0.25})),
                item=ItemSpec("toy", (0.07, 0.07, 0.06), "cavity", goal_xy=(0.5, 0.22)),
                reward=transport_reward),
    BehaviorDef("carry_bucket", "the robot carries the bucket", ("bucket", "carry"),
                "bucket", "bucket", (0.5, -0.25), 0.0, "carry", 0.0,
                _calls(("moved", ["F"], {"distance": 0.3}), ("holding", ["robot", "F"], {}, True)),
                item=ItemSpec("bucket", (0.22, 0.22, 0.31), "floor", goal_xy=(0.5, 0.25)),
                reward=transport_reward),
]}

# Assets that may stand in for a behavior's default item (a path entity such as
# 'frozen_vegetables' becomes the thing retrieved from the fridge).
ITEM_ASSETS = ("cup", "book", "toy", "fruit", "bottle", "clothes", "frozen_vegetables", "dishes")


def get_behavior(behavior_id: str) -> BehaviorDef:
    try:
        return BEHAVIORS[behavior_id]
    except KeyError:
        raise ConfigError(f"unknown manipulation behavior {behavior_id!r}; known: "
                          f"{', '.join(sorted(BEHAVIORS))}") from None


def match_behavior(text: str) -> BehaviorDef:
    """The behavior a text describes, by keyword score (longer phrases weigh more)."""
    low = " ".join(re.findall(r"[a-z]+", text.lower()))
    scores: dict[str, int] = {}
    for b in BEHAVIORS.values():
        score = sum(len(k) for k in b.keywords if re.search(rf"\b{re.escape(k)}", low))
        if score:
            scores[b.id] = score
    if not scores:
        raise ConfigError(f"no manipulation behavior matches {text!r}; name one with "
                          f"--reward (the reward parameter), one of: {', '.join(sorted(BEHAVIORS))}")
    best = max(scores.values())
    winners = sorted(k for k, v in scores.items() if v == best)
    if len(winners) > 1:
        raise ConfigError(f"the text {text!r} matches several behaviors equally ({', '.join(winners)}); "
                          "give --reward (the reward parameter) to choose")
    return BEHAVIORS[winners[0]]


def resolve(reward: str | None, text: str) -> BehaviorDef:
    """The behavior named by ``reward``, else the one the text describes."""
    return get_behavior(reward) if reward else match_behavior(text)
