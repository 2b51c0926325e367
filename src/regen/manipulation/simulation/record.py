"""Record a running manipulation scene into a :class:`Trace`.

Trace contents, recorded at ``RECORD_HZ``: every body's AABB centre (x, y, z) and extents; the
robot's end effector (``ee_x/y/z``), what it holds (``holding``), its joint angles (``q0``..``q8``,
for replay) and, when ``Recorder.command`` is kept up to date (the rollout does), the joint targets
the controller last commanded (``cmd_q0``..``cmd_q8``: 7 arm [rad], 2 fingers [m]; optional, traces
recorded before them lack them); furniture ``joint_fraction``, ``joint_position``, handle point
(``handle_x/y/z``), interior (``cavity_lo_x`` .. ``cavity_hi_z``), ``top`` height and the
meaning of the joint when it has one (``power``/``water`` on/off). With ``Recorder.watch`` set
(policy tests) also the robot's ``contacts`` (the watched bodies any robot link touched since
the previous sample, comma-separated) and each object's ``tilt`` [rad] from upright.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from regen.core.scenario import Scenario
from regen.core.trace import ActorTrack, Trace
from regen.manipulation.simulation.layout import DT
from regen.manipulation.simulation.scene import Scene
from regen.manipulation.world.setting import ManipulationWorld

RECORD_HZ = 24  # trace samples per simulated second
ON_FRACTION = 0.5  # a switch/lever/knob counts as 'on' beyond this opening


@dataclass
class Recorder:
    """Samples the scene every ``every`` physics steps into columnar lists."""

    scene: Scene
    every: int = int(round(1 / (DT * RECORD_HZ)))
    steps: int = 0
    times: list[float] = field(default_factory=list)
    tracks: dict[str, dict[str, list]] = field(default_factory=dict)
    holding: str | None = None
    meaning: dict[str, str] = field(default_factory=dict)  # furniture -> state key it drives
    # bodies whose contacts with the robot are recorded, checked every physics step: a touch
    # lasting less than a sample period (1/24 s) must not slip through
    watch: tuple[str, ...] = ()
    touched: set[str] = field(default_factory=set)
    # the controller's last joint targets, set by whoever drives the robot (None: not recorded)
    command: list[float] | None = None

    def __call__(self) -> None:
        self.steps += 1
        if self.watch:
            s = self.scene
            for name in self.watch:
                if name not in self.touched and s.contact("robot", name):
                    self.touched.add(name)
        if (self.steps - 1) % self.every == 0:
            self.sample()

    def _put(self, name: str, key: str, value: object) -> None:
        self.tracks.setdefault(name, {}).setdefault(key, []).append(value)

    def sample(self) -> None:
        s = self.scene
        self.times.append(round(self.steps * DT, 5))
        for name, b in s.bodies.items():
            if b.is_robot:
                self._put(name, "x", b.origin[0])
                self._put(name, "y", b.origin[1])
                self._put(name, "z", b.origin[2])
                ee = s.ee_position()
                for k, v in zip(("ee_x", "ee_y", "ee_z"), ee, strict=True):
                    self._put(name, k, round(float(v), 4))
                self._put(name, "holding", self.holding or "")
                for i, q in enumerate(s.arm_state()):
                    self._put(name, f"q{i}", round(q, 4))
                if self.command is not None:
                    for i, q in enumerate(self.command):
                        self._put(name, f"cmd_q{i}", round(float(q), 4))
                if self.watch:
                    self._put(name, "contacts", ",".join(sorted(self.touched)))
                    self.touched.clear()
                continue
            box = s.aabb(name, -1 if b.kind == "furniture" else None)
            centre = [(lo + hi) / 2 for lo, hi in zip(box.lo, box.hi, strict=True)]
            for k, v in zip(("x", "y", "z"), centre, strict=True):
                self._put(name, k, round(v, 4))
            self._put(name, "heading", round(s.yaw(name), 4))
            if b.power is not None:  # a context device keeps the state it is drawn in
                self._put(name, "power", b.power)
            if self.watch:
                self._put(name, "tilt", round(s.tilt(name), 4))
            if b.kind == "furniture" and b.spec is not None:
                spec = b.spec
                frac = s.joint_fraction(name)
                self._put(name, "joint_fraction", round(frac, 4))
                self._put(name, "joint_position", round(s.joint_position(name), 4))
                h = s.handle_position(name) if spec.handle_link else (0.0, 0.0, 0.0)
                for k, v in zip(("handle_x", "handle_y", "handle_z"), h, strict=True):
                    self._put(name, k, round(float(v), 4))
                cav = s.cavity(name)
                if cav is not None:
                    for k, v in zip(("lo_x", "lo_y", "lo_z", "hi_x", "hi_y", "hi_z"),
                                    (*cav.lo, *cav.hi), strict=True):
                        self._put(name, f"cavity_{k}", round(float(v), 4))
                if spec.top is not None:
                    self._put(name, "top", round(box.lo[2] + spec.top, 4))
                if spec.under is not None:
                    self._put(name, "under", round(box.lo[2] + spec.under, 4))
                if name in self.meaning:
                    self._put(name, self.meaning[name], "on" if frac > ON_FRACTION else "off")

    def trace(self, scenario: Scenario) -> Trace:
        actors: dict[str, ActorTrack] = {}
        n = len(self.times)
        for e in scenario.entities:
            cols = self.tracks.get(e.name)
            if cols is None:
                continue
            b = self.scene.bodies[e.name]
            if b.is_robot:
                size = b.size
            elif b.kind == "furniture":
                size = self.scene.aabb(e.name, -1).size
            else:
                size = b.size
            xs, ys = cols.pop("x"), cols.pop("y")
            zs = cols.pop("z")
            heading = cols.pop("heading", [])
            speed = [0.0] + [math.hypot(xs[i] - xs[i - 1], ys[i] - ys[i - 1]) * RECORD_HZ
                             for i in range(1, n)]
            actors[e.name] = ActorTrack(asset=e.asset, kind=e.kind, length=size[0], width=size[1],
                                        height=size[2], x=xs, y=ys, z=zs, heading=heading,
                                        speed=[round(v, 4) for v in speed], states=cols)
        return Trace(dt=1.0 / RECORD_HZ, times=self.times, actors=actors,
                     meta={"simulator": "pybullet", "behavior": ManipulationWorld.of(scenario).behavior,
                           "physics_dt": DT, "physics_steps": self.steps})


__all__ = ["ON_FRACTION", "RECORD_HZ", "Recorder"]
