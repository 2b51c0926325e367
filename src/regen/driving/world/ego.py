"""The six ego behaviors of the paper (3.1) as route templates: start, waypoints, speed schedule.

The ego's behavior is the fixed input; the world around it is what grounding varies. Each
template knows its map, its route, its speed schedule and its *event*: the time ``t_event`` [s]
at which the behavior happens (the ego starts, brakes, changes lane), and the *frame* in which
other actors are placed: the road the ego is on at the event, as an origin, a unit direction
(the ego's direction of travel) and the lateral offset of the ego's lane.

Matching text to a template is keyword based (:func:`match_template`):

==========================  =============================================================
template id                 keywords (all of one row must appear, case-insensitive)
==========================  =============================================================
stop_in_intersection        stop + (intersection | junction | crossroad)
stop_after_turn             stop + (turn | turning)
change_lane                 lane + (change | changes | changing | switch | merge)
slow_down                   slow | decelerat
stop_abruptly               stop | brake | halt
drive_forward               drive | go | start | accelerat | forward | move
==========================  =============================================================

Rows are tried top to bottom; the first that matches wins.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field

from regen.driving.world.maps import ARM_LENGTH, JUNCTION_RADIUS, geometry
from regen.errors import ConfigError

MAX_BRAKE = 6.8  # Newtonian full-brake deceleration [m/s^2]
MAX_ACCEL = 5.6  # Newtonian full-throttle acceleration [m/s^2]
EGO_SIZE = (4.6, 1.9, 1.5)  # length, width, height [m]
JUNCTION_CX = ARM_LENGTH + JUNCTION_RADIUS  # x of the junction centre on junction maps [m]


@dataclass(frozen=True)
class Frame:
    """A road frame: P = origin + s * u + d * n, with n the left normal of u."""

    ox: float
    oy: float
    ux: float
    uy: float
    lanes_same_direction: int  # driving lanes in the ego's direction
    lane_width: float
    sidewalk_width: float

    def point(self, s: float, d: float) -> tuple[float, float]:
        return (self.ox + s * self.ux - d * self.uy, self.oy + s * self.uy + d * self.ux)

    @property
    def heading(self) -> float:
        """Direction of travel [rad], counter-clockwise from +x."""
        return math.atan2(self.uy, self.ux)

    def lane_d(self, k: int) -> float:
        """Lateral offset [m] of lane k: 0 innermost in the ego's direction, 1 next out;
        -1 innermost oncoming lane."""
        return -(k + 0.5) * self.lane_width if k >= 0 else (-k - 0.5) * self.lane_width

    def sidewalk_d(self, side: str = "right") -> float:
        off = self.lanes_same_direction * self.lane_width + self.sidewalk_width / 2
        return -off if side == "right" else off


@dataclass(frozen=True)
class EgoTemplate:
    id: str
    description: str
    map: str
    route: tuple[tuple[float, float], ...]  # [m]
    speed0: float  # [m/s]
    schedule: tuple[tuple[float, float, float], ...]  # (t_from [s], speed [m/s], brake 0..1)
    t_event: float  # [s] when the behavior happens
    duration: float  # [s] simulated
    frame: Frame  # the road the ego is on at the event
    s_event: float  # ego centre along the frame at t_event [m]
    speed_event: float  # ego speed just before the event [m/s]
    ego_lane: int  # lane index of the ego in the frame at the event
    stops: bool = False
    s_end: float = 0.0  # where the ego is at the end [m] (frame)
    junction_maps: tuple[str, ...] = ()  # maps it can also run on (same geometry of the event)
    needs: tuple[str, ...] = field(default_factory=tuple)  # what the map must offer


def _straight_frame() -> Frame:
    g = geometry("straight")
    return Frame(0.0, 0.0, 1.0, 0.0, g.lanes_per_direction, g.lane_width, g.sidewalk_width)


def _junction_frame(name: str, direction: str = "east") -> Frame:
    g = geometry(name)
    if direction == "east":
        return Frame(JUNCTION_CX, 0.0, 1.0, 0.0, 1, g.lane_width, g.sidewalk_width)
    return Frame(JUNCTION_CX, 0.0, 0.0, -1.0, 1, g.lane_width, g.sidewalk_width)  # south-bound


def _line(a: tuple[float, float], b: tuple[float, float], step: float = 5.0) -> list[tuple[float, float]]:
    n = max(1, int(math.hypot(b[0] - a[0], b[1] - a[1]) // step))
    return [(a[0] + (b[0] - a[0]) * i / n, a[1] + (b[1] - a[1]) * i / n) for i in range(n + 1)]


def arc(center: tuple[float, float], radius: float, a0: float, a1: float,
        step: float = 1.5) -> list[tuple[float, float]]:
    """Points on a circle arc from angle a0 to a1 [rad] about ``center``."""
    n = max(2, int(abs(a1 - a0) * radius // step))
    return [(center[0] + radius * math.cos(a0 + (a1 - a0) * i / n),
             center[1] + radius * math.sin(a0 + (a1 - a0) * i / n)) for i in range(n + 1)]


def stop_distance(v: float, decel: float = MAX_BRAKE) -> float:
    """Distance [m] to stop from speed v [m/s] at deceleration decel [m/s^2] (with 0.1 s lag)."""
    return v * v / (2 * decel) + 0.1 * v


def _build() -> dict[str, EgoTemplate]:
    fs = _straight_frame()
    w = fs.lane_width
    out: dict[str, EgoTemplate] = {}
    # straight road, lane 0 (inner east-bound lane), start at x = -150
    y0 = fs.lane_d(0)
    v, te = 10.0, 6.0
    s_e = -150 + v * te
    out["stop_abruptly"] = EgoTemplate(
        "stop_abruptly", "drives forward at 10 m/s and stops abruptly (full brake)", "straight",
        tuple(_line((-150, y0), (190, y0))), v, ((0.0, v, 0.0), (te, 0.0, 1.0)), te, 16.0, fs,
        s_e, v, 0, True, s_e + stop_distance(v), junction_maps=("four_way",))
    v2 = 12.0
    s_e2 = -150 + v2 * te
    out["slow_down"] = EgoTemplate(
        "slow_down", "drives forward at 12 m/s and slows down to 4 m/s", "straight",
        tuple(_line((-150, y0), (190, y0))), v2, ((0.0, v2, 0.0), (te, 4.0, 0.35)), te, 16.0, fs,
        s_e2, v2, 0, False, s_e2 + 32 + 4.0 * (16.0 - te - 3.0), junction_maps=("four_way",))
    t_go = 4.0
    out["drive_forward"] = EgoTemplate(
        "drive_forward", "waits stationary, then drives forward, accelerating to 10 m/s",
        "straight", tuple(_line((-120, y0), (190, y0))), 0.0,
        ((0.0, 0.0, 1.0), (t_go, 10.0, 0.0)), t_go, 16.0, fs, -120.0, 0.0, 0, False,
        -120.0 + 10.0 * (16.0 - t_go) - 9.0, junction_maps=("four_way",))
    y1 = fs.lane_d(1)
    s_c = -150 + v * te
    out["change_lane"] = EgoTemplate(
        "change_lane", "drives forward at 10 m/s in the outer lane and changes into the inner lane",
        "straight", tuple(_line((-150, y1), (s_c, y1)) + _line((s_c + 25, y0), (190, y0))), v,
        ((0.0, v, 0.0),), te, 16.0, fs, s_c, v, 1, False, -150 + v * 16.0, needs=("two_lanes",))
    # junction maps: the ego comes from the west arm on the east-bound lane (y = -w/2)
    cx, r = JUNCTION_CX, JUNCTION_RADIUS
    yj = -w / 2
    vj = 8.0
    x_entry = cx - r
    t_entry = 60.0 / vj
    te_j = t_entry + 0.6
    fj = _junction_frame("four_way")
    s_ej = -r - 60 + vj * te_j
    out["stop_in_intersection"] = EgoTemplate(
        "stop_in_intersection", "drives straight into the four-way junction and stops abruptly in it",
        "four_way", tuple(_line((x_entry - 60, yj), (cx + r + 100, yj))), vj,
        ((0.0, vj, 0.0), (te_j, 0.0, 1.0)), te_j, 14.0, fj, s_ej, vj, 0, True,
        s_ej + stop_distance(vj), needs=("junction",))
    vt = 6.0
    rad = r - w / 2
    turn = arc((x_entry, -r), rad, math.pi / 2, 0.0)  # right turn: east-bound to south-bound
    route = _line((x_entry - 50, yj), (x_entry, yj)) + turn[1:] + _line((cx - w / 2, -r), (cx - w / 2, -r - 120))[1:]
    t_turn_end = (50 + rad * math.pi / 2) / vt
    te_t = t_turn_end + 2.5
    ft = _junction_frame("t_junction", "south")
    s_et = r + vt * (te_t - t_turn_end)
    out["stop_after_turn"] = EgoTemplate(
        "stop_after_turn", "turns right at the T-junction at 6 m/s, then stops abruptly",
        "t_junction", tuple(route), vt, ((0.0, vt, 0.0), (te_t, 0.0, 1.0)), te_t, te_t + 6.0, ft,
        s_et, vt, 0, True, s_et + stop_distance(vt), junction_maps=("four_way",), needs=("junction",))
    return out


EGO_TEMPLATES: dict[str, EgoTemplate] = _build()

_RULES: list[tuple[str, list[tuple[str, ...]]]] = [
    ("stop_in_intersection", [("stop", "halt", "brake"), ("intersection", "junction", "crossroad")]),
    ("stop_after_turn", [("stop", "halt", "brake"), ("turn",)]),
    ("change_lane", [("lane",), ("chang", "switch", "merge")]),
    ("slow_down", [("slow", "decelerat")]),
    ("stop_abruptly", [("stop", "brake", "halt")]),
    ("drive_forward", [("driv", "go", "start", "accelerat", "forward", "move")]),
]


def match_template(text: str) -> str:
    """The ego template id for a behavior text (keyword rules above); ConfigError if none."""
    words = re.findall(r"[a-z]+", text.lower())
    for tid, groups in _RULES:
        if all(any(w.startswith(k) for w in words for k in group) for group in groups):
            return tid
    raise ConfigError(f"no ego template matches {text!r}; name one with ego_template= "
                      f"({', '.join(EGO_TEMPLATES)})")


def template_for(behavior_text: str, template_id: str | None = None) -> EgoTemplate:
    """The template named by ``template_id``, else the one matched from the text."""
    tid = template_id or match_template(behavior_text)
    if tid not in EGO_TEMPLATES:
        raise ConfigError(f"unknown ego template {tid!r}; choose one of: {', '.join(EGO_TEMPLATES)}")
    return EGO_TEMPLATES[tid]


def on_junction_map(t: EgoTemplate, map_name: str) -> EgoTemplate:
    """A straight-road template moved onto the approach of a junction map (same timing)."""
    if map_name == t.map:
        return t
    if map_name not in t.junction_maps:
        raise ConfigError(f"ego template {t.id!r} cannot run on map {map_name!r}")
    if t.id == "stop_after_turn":
        return EgoTemplate(**{**t.__dict__, "map": map_name,
                              "frame": _junction_frame(map_name, "south")})
    fr = _junction_frame(map_name)
    # shift the route so that the ego stops (or its event happens) short of the junction entry
    target = -JUNCTION_RADIUS - 6.0
    shift_s = target - t.s_end if t.stops else target - 20.0 - t.s_event
    route = tuple((JUNCTION_CX + x + shift_s, fr.lane_d(0)) for x, _ in t.route
                  if JUNCTION_CX + x + shift_s > 0.5)
    return EgoTemplate(**{**t.__dict__, "map": map_name, "frame": fr, "route": route,
                          "s_event": t.s_event + shift_s, "s_end": t.s_end + shift_s})
