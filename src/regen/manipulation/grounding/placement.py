"""Place context objects with CP-SAT: spatial relations over a 1 cm grid.

Relations (the fixed list the model chooses from): ``on``, ``in``, ``under``, ``near``,
``left_of``, ``right_of``, ``in_front_of``, ``behind``, ``outside`` (the far side of a door's
or window's wall) and ``out_of_reach`` (of the robot). References are the scene's fixed things:
the robot, the table and the behavior's furniture.

Constraints: the relation itself; non-overlap with other objects on the same support and with
fixed obstacles; support (an object ``on`` or ``in`` something must fit its top or interior);
reachability (floor objects keep out of the robot's working corridor and of the furniture's
swing, so they never block the behavior). Structural impossibilities (something ``in`` a table,
which has no interior, as in the paper's "objects inside a table closet") are reported before
solving; geometric ones come from CP-SAT as a minimal conflict set over one named constraint per
relation (:class:`regen.cpsat.NamedModel`).
"""

from __future__ import annotations

import random
import time
from dataclasses import dataclass, field
from typing import Any

from regen.cpsat import NamedModel
from regen.manipulation.world.furniture import AABB, furniture
from regen.manipulation.world.tasks import BehaviorDef

RELATIONS: dict[str, str] = {
    "on": "on top of the reference (table, cabinet, oven ...)",
    "in": "inside the reference's interior (drawer, cabinet, fridge, box, sink)",
    "under": "on the floor under the reference (table)",
    "near": "on the floor next to the reference",
    "left_of": "on the floor left of the reference, seen from the robot",
    "right_of": "on the floor right of the reference, seen from the robot",
    "in_front_of": "on the floor between the reference and the robot",
    "behind": "on the floor beyond the reference, seen from the robot",
    "outside": "on the other side of the reference's wall (outside the door or window)",
    "out_of_reach": "on the floor farther than the robot can reach",
}
UNIT = 0.01  # grid cell [m]
NEAR = 0.3  # [m] largest gap per axis for 'near' (the predicate checks 0.45 m diagonally)
SIDE_RANGE = 0.8  # [m] how far 'left of', 'in front of', 'behind' ... may reach out
CLEAR = 0.03  # [m] gap kept between objects
REACH = 0.9  # [m] the Panda's reach from its base (it is 0.855 m)
ROOM = AABB((-1.2, -1.6, 0.0), (2.2, 1.6, 2.5))  # floor area objects may use [m]
TABLE_XY = (0.1, 0.85)  # [m] where the table stands


@dataclass
class Ref:
    """A fixed thing objects can be placed relative to (world frame, metres)."""

    name: str
    kind: str  # robot, table, furniture
    lo: tuple[float, float]
    hi: tuple[float, float]
    top: float | None = None
    cavity: AABB | None = None
    cavity_moves: bool = False
    under: float | None = None
    wall: bool = False
    opening: tuple[float, float] | None = None  # y-range of a door/window opening [m]

    @property
    def is_robot(self) -> bool:
        return self.kind == "robot"


@dataclass
class Request:
    name: str
    asset: str
    size: tuple[float, float, float]  # length (x), width (y), height (z) [m]
    relation: str
    reference: str


@dataclass
class Placed:
    name: str
    x: float  # bottom centre [m]
    y: float
    z: float  # support height [m]
    dynamic: bool  # rides on a moving part (drawer), so it must be a free body
    support: str  # floor, 'top of X', 'inside X'


@dataclass
class PlacementResult:
    status: str  # optimal, feasible, infeasible, model_invalid, unknown
    placed: dict[str, Placed] = field(default_factory=dict)
    conflicts: list[str] = field(default_factory=list)
    wall_time: float = 0.0  # [s]
    # when infeasible: the relations in a minimal conflict set, as "object relation reference"
    # (dropping any one of them makes the placement feasible); empty when none conflict
    core: list[str] = field(default_factory=list)


@dataclass
class SceneGeometry:
    refs: dict[str, Ref]
    keepouts: list[tuple[str, AABB]]  # floor areas no context object may use
    occupied: dict[str, list[tuple[str, AABB]]] = field(default_factory=dict)  # support -> boxes


def scene_geometry(behavior: BehaviorDef, furniture_name: str, item_box: AABB | None) -> SceneGeometry:
    """The fixed things of a behavior's scene: robot, table, furniture, and what to keep clear."""
    spec = furniture(behavior.furniture)
    fx, fy = behavior.pose
    fp = spec.footprint
    refs = {
        "robot": Ref("robot", "robot", (-0.12, -0.12), (0.12, 0.12)),
    }
    table = furniture("table")
    tx, ty = TABLE_XY
    refs["table"] = Ref("table", "table", (tx + table.footprint.lo[0], ty + table.footprint.lo[1]),
                        (tx + table.footprint.hi[0], ty + table.footprint.hi[1]), top=table.top,
                        under=table.under)
    cavity = None
    if spec.cavity is not None and not spec.dynamic:
        c = spec.cavity
        shift = 0.0
        if spec.cavity_link:  # a drawer: its interior sits where the drawer is
            shift = -behavior.start_fraction * (spec.opened - spec.closed)
        cavity = AABB((c.lo[0] + fx + shift, c.lo[1] + fy, c.lo[2]), (c.hi[0] + fx + shift, c.hi[1] + fy, c.hi[2]))
    opening = None
    if spec.wall:
        opening = (fy - 0.6, fy + 0.6)
    refs[furniture_name] = Ref(furniture_name, "furniture", (fx + fp.lo[0], fy + fp.lo[1]),
                               (fx + fp.hi[0], fy + fp.hi[1]), top=spec.top, cavity=cavity,
                               cavity_moves=bool(spec.cavity_link), under=spec.under,
                               wall=spec.wall, opening=opening)
    keep: list[tuple[str, AABB]] = []
    front = fx + fp.lo[0]
    keep.append(("the robot's working corridor", AABB((-0.3, -0.4, 0), (max(front, 0.35), 0.4, 2))))
    if spec.sweep is not None:
        s = spec.sweep
        keep.append((f"the swing of the {behavior.furniture}",
                     AABB((fx + s.lo[0], fy + s.lo[1], 0), (fx + s.hi[0], fy + s.hi[1], 2))))
    occupied: dict[str, list[tuple[str, AABB]]] = {}
    if item_box is not None:
        # the hand is 0.21 m across its fingers (along y) and 0.07 m thick: keep room for it
        keep.append(("the item the robot moves and the hand around it",
                     AABB((item_box.lo[0] - 0.06, item_box.lo[1] - 0.14, 0),
                          (item_box.hi[0] + 0.06, item_box.hi[1] + 0.14, 1))))
        if cavity is not None:
            occupied.setdefault(f"in:{furniture_name}", []).append(("the item the robot moves", item_box))
    if behavior.item is not None and behavior.item.start == "cavity" or behavior.script == "carry":
        assert behavior.item is not None
        gx, gy = behavior.item.goal_xy
        keep.append(("where the robot puts the item down",
                     AABB((gx - 0.18, gy - 0.18, 0), (gx + 0.18, gy + 0.18, 1))))
    return SceneGeometry(refs, keep, occupied)


def _cm(v: float) -> int:
    return int(round(v / UNIT))


def structural_problems(req: Request, refs: dict[str, Ref]) -> list[str]:
    """Why a relation cannot hold whatever the positions are (empty when it can)."""
    length, w, h = req.size
    ref = refs.get(req.reference)
    what = f"{req.name} {req.relation.replace('_', ' ')} {req.reference}"
    if req.relation not in RELATIONS:
        return [f"{what}: unknown relation {req.relation!r}; use one of {', '.join(RELATIONS)}"]
    if ref is None:
        return [f"{what}: unknown reference {req.reference!r}; use one of {', '.join(refs)}"]
    if req.relation == "on":
        if ref.top is None:
            return [f"{what}: the {ref.name} has no top surface that can support objects"]
        if length > ref.hi[0] - ref.lo[0] or w > ref.hi[1] - ref.lo[1]:
            return [f"{what}: {req.asset} ({length:.2f} x {w:.2f} m) is larger than the top of the "
                    f"{ref.name} ({ref.hi[0] - ref.lo[0]:.2f} x {ref.hi[1] - ref.lo[1]:.2f} m)"]
    if req.relation == "in":
        if ref.cavity is None:
            return [f"{what}: the {ref.name} has no interior that can host objects"]
        cl, cw, ch = ref.cavity.size
        if length > cl or w > cw or h > ch:
            return [f"{what}: {req.asset} ({length:.2f} x {w:.2f} x {h:.2f} m) does not fit the "
                    f"interior of the {ref.name} ({cl:.2f} x {cw:.2f} x {ch:.2f} m)"]
    if req.relation == "under":
        if ref.under is None:
            return [f"{what}: the {ref.name} stands on the floor; there is no room under it"]
        if h > ref.under:
            return [f"{what}: {req.asset} ({h:.2f} m tall) does not fit under the {ref.name} "
                    f"({ref.under:.2f} m free)"]
    if req.relation == "outside" and not ref.wall:
        return [f"{what}: the {ref.name} has no wall with a door or window to be outside of"]
    if req.relation == "out_of_reach" and not ref.is_robot:
        return [f"{what}: 'out of reach' is measured from the robot; use reference 'robot'"]
    if ref.is_robot and req.relation in ("on", "in", "under", "in_front_of", "behind", "outside"):
        return [f"{what}: the robot cannot be a reference for {req.relation!r}; use near, "
                "left_of, right_of or out_of_reach"]
    return []


def solve_placement(requests: list[Request], geometry: SceneGeometry, *, seed: int = 0,
                    time_limit: float = 5.0,
                    spots: dict[str, tuple[float, float]] | None = None) -> PlacementResult:
    """Solve all placements at once; infeasible results name the relations in conflict.

    Each object is kept as close as it may be to a preferred spot [m]: a seeded random point of
    the room, or ``spots[name]`` where given (policy-test variants ask for the room's corners)."""
    t0 = time.perf_counter()
    problems = [p for r in requests for p in structural_problems(r, geometry.refs)]
    if problems:
        return PlacementResult("infeasible", conflicts=problems, wall_time=time.perf_counter() - t0)
    rng = random.Random(seed)
    model = PlacementModel(geometry)
    for r in requests:
        model.place(r, rng, spots)
    model.keep_apart(requests)
    model.m.Minimize(sum(model.objective))
    out = model.named.solve(time_limit, seed=seed)
    return model.result(out, requests, time_limit, time.perf_counter() - t0)


class PlacementModel:
    """The CP-SAT model of one placement: a position per object on the 1 cm grid, one named
    constraint per relation (:meth:`place`), no overlaps (:meth:`keep_apart`) and the solution
    read back (:meth:`result`)."""

    def __init__(self, geometry: SceneGeometry) -> None:
        self.geometry = geometry
        self.named = NamedModel()  # one named constraint per relation
        self.m = self.named.m
        self.xs: dict[str, Any] = {}
        self.ys: dict[str, Any] = {}
        self.groups: dict[str, list[str]] = {}  # support -> the objects on it
        self.support: dict[str, tuple[str, float, bool]] = {}  # object -> (group, z [m], dynamic)
        self.objective: list[Any] = []

    def place(self, r: Request, rng: random.Random, spots: dict[str, tuple[float, float]] | None) -> None:
        """The object's position variables, its relation and its preferred spot."""
        m = self.m
        length, w, _h = r.size
        hl, hw = _cm(length / 2), _cm(w / 2)
        x = m.NewIntVar(_cm(ROOM.lo[0]) + hl, _cm(ROOM.hi[0]) - hl, f"x_{r.name}")
        y = m.NewIntVar(_cm(ROOM.lo[1]) + hw, _cm(ROOM.hi[1]) - hw, f"y_{r.name}")
        self.xs[r.name], self.ys[r.name] = x, y
        lit = self.named.literal(f"{r.name} {r.relation.replace('_', ' ')} {r.reference}")
        group, z, dyn = self._relate(r, x, y, hl, hw, lit)
        self.support[r.name] = (group, z, dyn)
        self.groups.setdefault(group, []).append(r.name)
        # a seeded preferred spot: the solver keeps each object as close to it as it may
        px, py = rng.uniform(ROOM.lo[0], ROOM.hi[0]), rng.uniform(ROOM.lo[1], ROOM.hi[1])
        if spots and r.name in spots:
            px, py = spots[r.name]
        for var, pref, name in ((x, px, "dx"), (y, py, "dy")):
            dev = m.NewIntVar(0, 10_000, f"{name}_{r.name}")
            m.AddAbsEquality(dev, var - _cm(pref))
            self.objective.append(dev)

    def _relate(self, r: Request, x: Any, y: Any, hl: int, hw: int, lit: Any) -> tuple[str, float, bool]:
        """The relation's constraints (enforced by ``lit``); returns (support group, z, dynamic)."""
        m = self.m
        ref = self.geometry.refs[r.reference]
        rx0, ry0, rx1, ry1 = _cm(ref.lo[0]), _cm(ref.lo[1]), _cm(ref.hi[0]), _cm(ref.hi[1])
        group, z, dyn = "floor", 0.0, False
        if r.relation == "on":
            group, z = f"on:{ref.name}", float(ref.top or 0.0)
            m.Add(x - hl >= rx0).OnlyEnforceIf(lit)
            m.Add(x + hl <= rx1).OnlyEnforceIf(lit)
            m.Add(y - hw >= ry0).OnlyEnforceIf(lit)
            m.Add(y + hw <= ry1).OnlyEnforceIf(lit)
        elif r.relation == "in":
            c = ref.cavity
            assert c is not None
            group, z, dyn = f"in:{ref.name}", c.lo[2], ref.cavity_moves
            m.Add(x - hl >= _cm(c.lo[0])).OnlyEnforceIf(lit)
            m.Add(x + hl <= _cm(c.hi[0])).OnlyEnforceIf(lit)
            m.Add(y - hw >= _cm(c.lo[1])).OnlyEnforceIf(lit)
            m.Add(y + hw <= _cm(c.hi[1])).OnlyEnforceIf(lit)
        elif r.relation == "under":
            group = f"under:{ref.name}"
            m.Add(x - hl >= rx0 + 4).OnlyEnforceIf(lit)  # clear of the legs
            m.Add(x + hl <= rx1 - 4).OnlyEnforceIf(lit)
            m.Add(y - hw >= ry0 + 4).OnlyEnforceIf(lit)
            m.Add(y + hw <= ry1 - 4).OnlyEnforceIf(lit)
        elif r.relation == "near":
            d = _cm(NEAR)
            m.Add(x + hl >= rx0 - d).OnlyEnforceIf(lit)
            m.Add(x - hl <= rx1 + d).OnlyEnforceIf(lit)
            m.Add(y + hw >= ry0 - d).OnlyEnforceIf(lit)
            m.Add(y - hw <= ry1 + d).OnlyEnforceIf(lit)
        elif r.relation in ("left_of", "right_of"):
            s = _cm(SIDE_RANGE)
            if r.relation == "left_of":
                m.Add(y - hw >= ry1 + _cm(CLEAR)).OnlyEnforceIf(lit)
                m.Add(y - hw <= ry1 + s).OnlyEnforceIf(lit)
            else:
                m.Add(y + hw <= ry0 - _cm(CLEAR)).OnlyEnforceIf(lit)
                m.Add(y + hw >= ry0 - s).OnlyEnforceIf(lit)
            m.Add(x >= rx0 - _cm(0.3)).OnlyEnforceIf(lit)
            m.Add(x <= rx1 + _cm(0.3)).OnlyEnforceIf(lit)
        elif r.relation in ("in_front_of", "behind", "outside"):
            s = _cm(SIDE_RANGE)
            if r.relation == "in_front_of":
                m.Add(x + hl <= rx0 - _cm(CLEAR)).OnlyEnforceIf(lit)
                m.Add(x + hl >= rx0 - s).OnlyEnforceIf(lit)
            else:
                m.Add(x - hl >= rx1 + _cm(CLEAR)).OnlyEnforceIf(lit)
                m.Add(x - hl <= rx1 + s).OnlyEnforceIf(lit)
            band = ref.opening if r.relation == "outside" and ref.opening else (ref.lo[1], ref.hi[1])
            m.Add(y >= _cm(band[0])).OnlyEnforceIf(lit)
            m.Add(y <= _cm(band[1])).OnlyEnforceIf(lit)
        elif r.relation == "out_of_reach":
            far = _cm(REACH) + 2
            sides = [m.NewBoolVar(f"far{i}_{r.name}") for i in range(4)]
            m.Add(x - hl >= far).OnlyEnforceIf(sides[0])
            m.Add(x + hl <= -far).OnlyEnforceIf(sides[1])
            m.Add(y - hw >= far).OnlyEnforceIf(sides[2])
            m.Add(y + hw <= -far).OnlyEnforceIf(sides[3])
            m.AddBoolOr(sides).OnlyEnforceIf(lit)
        return group, z, dyn

    def keep_apart(self, requests: list[Request]) -> None:
        """Objects on the floor (or under the table) overlap neither each other nor the fixed
        things and keep-out areas; objects on one top or in one interior do not overlap."""
        sizes = {r.name: (_cm(r.size[0] / 2), _cm(r.size[1] / 2)) for r in requests}
        groups, refs = self.groups, self.geometry.refs
        floor_like = {g for g in groups if g == "floor" or g.startswith("under:")}
        for g, names in groups.items():
            peers = [n for gg in (floor_like if g in floor_like else {g}) for n in groups[gg]]
            for a in names:
                for b_ in peers:
                    if a >= b_:
                        continue
                    self._apart_pair(a, b_, sizes)
            for a in names:
                for _label, box in self.geometry.occupied.get(g, []):
                    self._apart_from_box(a, box, "occ", sizes)
                if g in floor_like:
                    # fixed things on the floor and the keep-out areas (reachability)
                    for ref in refs.values():
                        if g == f"under:{ref.name}":
                            continue
                        self._apart_from_box(a, AABB((*ref.lo, 0), (*ref.hi, 1)), f"ref_{ref.name}", sizes)
                    for i, (_label, box) in enumerate(self.geometry.keepouts):
                        self._apart_from_box(a, box, f"keep{i}", sizes)

    def _apart_pair(self, a: str, b_: str, sizes: dict[str, tuple[int, int]]) -> None:
        m, xs, ys, gap = self.m, self.xs, self.ys, _cm(CLEAR)
        ha, wa = sizes[a]
        hb, wb = sizes[b_]
        bs = [m.NewBoolVar(f"sep_{a}_{b_}_{i}") for i in range(4)]
        m.Add(xs[a] + ha + gap <= xs[b_] - hb).OnlyEnforceIf(bs[0])
        m.Add(xs[b_] + hb + gap <= xs[a] - ha).OnlyEnforceIf(bs[1])
        m.Add(ys[a] + wa + gap <= ys[b_] - wb).OnlyEnforceIf(bs[2])
        m.Add(ys[b_] + wb + gap <= ys[a] - wa).OnlyEnforceIf(bs[3])
        m.AddBoolOr(bs)

    def _apart_from_box(self, n: str, box: AABB, tag: str, sizes: dict[str, tuple[int, int]]) -> None:
        m, gap = self.m, _cm(CLEAR)
        hl, hw = sizes[n]
        b = [m.NewBoolVar(f"{tag}_{n}_{i}") for i in range(4)]
        m.Add(self.xs[n] + hl + gap <= _cm(box.lo[0])).OnlyEnforceIf(b[0])
        m.Add(self.xs[n] - hl - gap >= _cm(box.hi[0])).OnlyEnforceIf(b[1])
        m.Add(self.ys[n] + hw + gap <= _cm(box.lo[1])).OnlyEnforceIf(b[2])
        m.Add(self.ys[n] - hw - gap >= _cm(box.hi[1])).OnlyEnforceIf(b[3])
        m.AddBoolOr(b)

    def result(self, out: Any, requests: list[Request], time_limit: float, wall: float) -> PlacementResult:
        """The placed objects of a solution, or why there is none."""
        if out.solved:
            placed = {}
            for r in requests:
                g, z, dyn = self.support[r.name]
                where = ("floor" if g == "floor" else g.replace("on:", "top of ").replace("in:", "inside ")
                         .replace("under:", "under "))
                placed[r.name] = Placed(r.name, out.value(self.xs[r.name]) * UNIT,
                                        out.value(self.ys[r.name]) * UNIT, z, dyn, where)
            return PlacementResult(out.status, placed, wall_time=wall)
        if out.status == "infeasible":
            if out.conflicts:
                why = ("these placements cannot all hold without overlapping each other, the fixed "
                       "furniture or the robot's working space: " + "; ".join(out.conflicts))
            else:
                why = "the objects do not fit the free floor and surfaces at all"
            return PlacementResult("infeasible", conflicts=[why], core=out.conflicts, wall_time=wall)
        name = out.cp_status.lower()
        return PlacementResult(out.status, conflicts=[f"CP-SAT returned {name} within {time_limit:.0f} s of solver work"],
                               wall_time=wall)


def describe_geometry(geometry: SceneGeometry) -> str:
    """One line per reference, for prompts: what it offers (top, interior, wall)."""
    lines = []
    for ref in geometry.refs.values():
        offers = []
        if ref.top is not None:
            offers.append("a top")
        if ref.cavity is not None:
            offers.append("an interior")
        if ref.under is not None:
            offers.append("room under it")
        if ref.wall:
            offers.append("a wall with an opening (outside)")
        lines.append(f"- {ref.name}: " + (", ".join(offers) if offers else "floor around it only"))
    return "\n".join(lines)


__all__ = ["RELATIONS", "Placed", "PlacementModel", "PlacementResult", "Ref", "Request", "SceneGeometry",
           "describe_geometry", "scene_geometry", "solve_placement", "structural_problems"]
