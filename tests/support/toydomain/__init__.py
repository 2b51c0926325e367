"""A third simulation domain, defined only in the tests: it proves that a domain can be added
without touching the toolkit's shared code. A robot drives down a warehouse aisle at 1.5 m/s
and stops for anything in the aisle ahead; workers may step into the aisle, pallets stand in it.
Simulation is a few lines of kinematics (this is a test double of a simulator, never a product).
"""

from __future__ import annotations

import json
from pathlib import Path

from PIL import Image, ImageDraw

from regen import media
from regen.contract import (
    ANIMATION,
    KEYFRAMES,
    DomainBackend,
    ReportHints,
    SimulationOutput,
    Wording,
)
from regen.core import (
    FSM,
    AbstractState,
    ActorTrack,
    Entity,
    PredicateCall,
    Scenario,
    Stage,
    StateRef,
    Trace,
)
from regen.core.io import atomic_write_text
from regen.errors import GroundingError

DT = 0.1  # [s]
STEPS = 80
SPEED = 1.5  # robot cruise speed [m/s]
STOP_GAP = 2.0  # the robot stops when something in the aisle is this close ahead [m]
START = {"beside_the_aisle_ahead": (8.0, 1.5), "in_the_aisle_ahead": (8.0, 0.0)}  # [m]


class AisleBackend(DomainBackend):
    name = "aisle"
    database_resource = ("toydomain", "data/assets.json")
    predicates_module = "toydomain.predicates"
    wording = Wording(expert="warehouse logistics", situation="warehouse",
                      cause_rule="Each cause must be something in the warehouse, not the robot's own mechanics.",
                      value_hint='relative to the robot, e.g. "in the aisle ahead"')
    report_hints = ReportHints(animation="top view of the aisle", keyframes="start and end", robot="robot")

    def ground(self, path, llm, *, seed=0):
        entities = [Entity(name="robot", asset="robot", kind="robot")]
        states = [AbstractState(name="stopped", actor="robot",
                                all_of=[PredicateCall(name="stopped", args=["robot"])])]
        first = []
        for i, pe in enumerate(path.entities, start=1):
            name = f"{pe.asset}{i}"
            behavior = (pe.properties.get("behavior") or ["stationary"])[0]
            start = (pe.properties.get("start_location") or ["in_the_aisle_ahead"])[0]
            if behavior == "stationary" and start == "beside_the_aisle_ahead":
                raise GroundingError(f"a {pe.asset} that stays beside the aisle cannot stop the robot")
            entities.append(Entity(name=name, asset=pe.asset, behavior=behavior,
                                   properties={"start_location": start}))
            states.append(AbstractState(name="in_aisle", actor=name,
                                        all_of=[PredicateCall(name="in_aisle", args=[name])]))
            first.append(StateRef(actor=name, state="in_aisle"))
        if not first:
            raise GroundingError("the cause names no entity of the aisle domain")
        fsm = FSM(states=states, stages=[Stage(conditions=first),
                                         Stage(conditions=[StateRef(actor="robot", state="stopped")])])
        return Scenario(id=path.key, domain=self.name, behavior=path.behavior, causal_graph=path.events,
                        narrative="Something enters the aisle ahead, so the robot stops.", entities=entities,
                        fsm=fsm, world={"dt": DT, "seed": seed})

    def simulate(self, scenario, workdir):
        times = [k * DT for k in range(STEPS)]
        others = {}
        for e in scenario.entities[1:]:
            x, y = START[e.properties["start_location"]]
            ys = [y if e.behavior != "step_into_aisle" or t < 1.0 else max(0.0, y - (t - 1.0)) for t in times]
            others[e.name] = ActorTrack(asset=e.asset, x=[x] * STEPS, y=ys, speed=[0.0] * STEPS,
                                        length=0.5, width=0.5)
        rx, speed, xs, speeds = 0.0, SPEED, [], []
        for k in range(STEPS):
            blocked = any(abs(a.y[k]) < 0.6 and 0 < a.x[k] - rx < STOP_GAP + 0.5 for a in others.values())
            speed = 0.0 if blocked else SPEED
            xs.append(rx)
            speeds.append(speed)
            rx += speed * DT
        actors = {"robot": ActorTrack(asset="robot", kind="robot", x=xs, y=[0.0] * STEPS, speed=speeds,
                                      length=0.8, width=0.6), **others}
        return SimulationOutput(trace=Trace(dt=DT, times=times, actors=actors))

    def render(self, scenario, trace, verdict, out_dir):
        frames = []
        for k in range(0, trace.steps, 10):
            img = Image.new("RGB", (200, 60), (245, 245, 245))
            d = ImageDraw.Draw(img)
            d.rectangle((0, 24, 199, 36), fill=(220, 220, 220))
            for name, a in trace.actors.items():
                cx, cy = 10 + a.x[k] * 15, 30 - a.y[k] * 15
                d.rectangle((cx - 4, cy - 4, cx + 4, cy + 4), fill=(200, 40, 40) if name == "robot" else (40, 40, 200))
            frames.append(img)
        out_dir = Path(out_dir)
        return {ANIMATION: media.write_gif(out_dir / "aisle.gif", frames, 100),
                KEYFRAMES: media.write_png(out_dir / "aisle.png", media.strip([frames[0], frames[-1]]))}

    def export(self, scenario, out_dir, trace=None):
        cfg = {"entities": [e.model_dump(mode="json") for e in scenario.entities]}
        return {"aisle_config": atomic_write_text(Path(out_dir) / "aisle.json", json.dumps(cfg))}
