"""What ``regen dataset`` draws and reads in driving (:class:`regen.contract.DatasetViews`).

The ego's reaction comes from its template (:mod:`regen.driving.world.egos`), the bird's-eye
frame from the run's own renderer (:mod:`regen.driving.render.frames`, the map window without the
caption band, which names the FSM stage reached: the answer), the forward view from
:mod:`regen.driving.render.camera` (the ``camera`` extra), and a test variant is simulated again
with its scripted ego as ``regen test`` checks it
(:func:`regen.driving.testing.variants.check_template`).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from regen.contract import DatasetViews
from regen.core.scenario import AbstractState, Scenario
from regen.core.trace import Trace
from regen.core.verdict import Verdict


class DrivingDatasetViews(DatasetViews):
    def reaction(self, scenario: Scenario) -> tuple[Callable[[AbstractState], bool],
                                                     tuple[AbstractState, list[AbstractState]]] | None:
        from regen.driving.world.egos.registry import EGO_TEMPLATES

        tid = scenario.world.get("ego_template")
        template = EGO_TEMPLATES.get(str(tid)) if tid else None
        return None if template is None else (template.is_reaction, template.ego_states())

    def camera_note(self) -> str:
        try:
            from regen.driving.render.camera import camera_available
        except ImportError as exc:
            return f"the camera renderer is not installed ({exc})"
        if not camera_available():
            return "the camera renderer is not available on this machine (camera_available() is False)"
        return ""

    def pictures(self, scenario: Scenario, trace: Trace, verdict: Verdict, steps: list[int], *,
                 map_path: Path | None, camera: tuple[int, int] | None) -> dict[str, Any]:
        from regen.driving.render.frames import Frames, story_of
        from regen.driving.render.roads import FRAME_W, MAP_H
        from regen.driving.render.scenario import scene

        actors, times, view, bg = scene(scenario, trace, f"scenario {scenario.id!r}")
        frames = Frames(bg, view, actors, story_of(scenario, trace, verdict), times)
        out: dict[str, Any] = {f"bev_{k}": frames.draw(i).crop((0, 0, FRAME_W, MAP_H))
                               for k, i in enumerate(steps)}
        if camera is not None:
            from regen.driving.render.camera import camera_frames

            shots = camera_frames(scenario, trace, [float(trace.times[i]) for i in steps],
                                  size=camera, map_path=map_path)
            out.update({f"camera_{k}": img for k, img in enumerate(shots)})
        return out

    def resimulate(self, scenario: Scenario) -> tuple[Trace | None, Verdict | None, Scenario, str]:
        from regen.driving.testing.variants import check_template

        got = check_template(scenario)
        return got.trace, got.verdict, got.judged or scenario, got.error or ""


__all__ = ["DrivingDatasetViews"]
