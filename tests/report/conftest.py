"""Small run folders built from the real pydantic models, for the report tests."""

from __future__ import annotations

import json
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

sys.path.insert(0, str(Path(__file__).parent))  # the tests folder is not a package
from report_runs import make_scenario, tiny_gif, tiny_png, verified  # noqa: E402

from regen.core.behavior import Behavior  # noqa: E402
from regen.core.graph import ScenarioGraph  # noqa: E402
from regen.core.io import write_json  # noqa: E402

RunBuilder = Callable[..., Path]


@pytest.fixture
def make_run(tmp_path: Path) -> RunBuilder:
    """Build a run folder: ``make_run([dict(...), ...], **run_json_overrides)``.

    Each scenario dict may hold: scenario (Scenario or None), verdict (Verdict or None),
    gif/keyframes/scenic/xosc/trace (bool), error (str), folder (name), raw files {name: text}.
    """
    counter = {"n": 0}

    def build(specs: list[dict[str, Any]] | None = None, *, graph_png: bool = True,
              graph_html: bool = True, behavior_text: str = "the ego-vehicle stops abruptly",
              **run_fields: Any) -> Path:
        counter["n"] += 1
        run = tmp_path / f"run{counter['n']}"
        (run / "scenarios").mkdir(parents=True)
        behavior = Behavior(text=behavior_text, domain="driving", params={"ego_template": "stop_abruptly"})
        folders = []
        for i, spec in enumerate(specs or [], start=1):
            name = spec.get("folder", f"{i:02d}-cause-{i}")
            folders.append(name)
            d = run / "scenarios" / name
            d.mkdir()
            sc = spec.get("scenario", make_scenario(i))
            if sc is not None:
                write_json(d / "scenario.json", {"scenario": sc.model_dump(mode="json"),
                                                 "config": {"behavior": behavior.text, "seed": i}})
            vd = spec.get("verdict", verified())
            if vd is not None:
                write_json(d / "verdict.json", vd)
            roles = {}  # what the domain's render/export returned, as the pipeline records it
            if spec.get("gif", True):
                tiny_gif(d / "bird_eye.gif")
                roles["animation"] = "bird_eye.gif"
            if spec.get("keyframes", True):
                tiny_png(d / "keyframes.png", (80, 20))
                roles["keyframes"] = "keyframes.png"
            for flag, fname in (("scenic", "scenario.scenic"), ("xosc", "scenario.xosc"),
                                ("trace", "trace.json")):
                if spec.get(flag, False):
                    (d / fname).write_text("x\n")
                    if flag != "trace":
                        roles[flag] = fname
            write_json(d / "files.json", roles)
            if "error" in spec:
                (d / "error.txt").write_text(spec["error"])
            for fname, text in spec.get("raw", {}).items():
                (d / fname).write_text(text)
            write_json(d / "timings.json", {"ground": 1.5, "simulate": 3.25})
        data: dict[str, Any] = {
            "behavior": behavior.model_dump(mode="json"),
            "settings": {"llm": "local", "depth": 2, "max_scenarios": 5, "seed": 0, "replay": False},
            "status": "done", "started": "2025-01-02T10:00:00+00:00",
            "finished": "2025-01-02T10:05:00+00:00",
            "timings": {"expand": 12.5, "ground": 30.0, "simulate": 40.25, "render": 5.0},
            "usage": {"total": {"calls": 9, "model_calls": 7, "cache_hits": 2, "reasks": 1,
                                "failures": 0, "input_tokens": 4321, "output_tokens": 765,
                                "latency": 55.5},
                      "by_purpose": {"expand": {"calls": 5, "model_calls": 4, "cache_hits": 1,
                                                "reasks": 0, "failures": 0, "input_tokens": 2000,
                                                "output_tokens": 400, "latency": 30.0},
                                     "ground": {"calls": 4, "model_calls": 3, "cache_hits": 1,
                                                "reasks": 1, "failures": 0, "input_tokens": 2321,
                                                "output_tokens": 365, "latency": 25.5}}},
            "scenarios": folders,
        }
        data.update(run_fields)
        (run / "run.json").write_text(json.dumps(data))
        write_json(run / "graph.json", ScenarioGraph.start(behavior))
        if graph_png:
            tiny_png(run / "graph.png", (120, 60))
        if graph_html:
            (run / "graph.html").write_text("<!DOCTYPE html><title>graph</title>")
        return run

    return build
