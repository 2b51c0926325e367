"""Record the offline model's real answers as JSON cassettes for the replay tests.

Usage: python scripts/record_cassettes.py [expand] [generate] [ground] [--llm local]

Prompts are part of each cache key: after changing a prompt template or an answer schema, run
this again and commit the new cassettes under tests/data/cassettes/. With ``--reuse``, the
answers of the committed cassette whose prompts did not change are kept (the model answers only
the new prompts) and the answers no prompt asks any more are dropped.
"""

from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
import time
from pathlib import Path

from regen.core.behavior import Behavior
from regen.expand import expand
from regen.llm import LLM
from regen.llm.cache import CallCache

OUT = Path(__file__).resolve().parents[1] / "tests" / "data" / "cassettes"
sys.path.insert(0, str(OUT.parents[1] / "support"))  # the table the replay tests read too
from cassette_cases import EXPANSIONS  # noqa: E402

GENERATE = ("generate_driving", Behavior(text="the ego-vehicle stops abruptly while driving forward",
                                         domain="driving"))


class UsedCache(CallCache):
    """A cache that remembers which entries were read or written, to export only those."""

    def __init__(self, path, seed: Path | None = None):
        super().__init__(path)
        if seed is not None and seed.exists():
            self.import_json(seed)
        self.used: set[str] = set()

    def get(self, key: str, *, failed: bool = False):
        got = super().get(key, failed=failed)
        if got is not None:
            self.used.add(key)
        return got

    def put(self, key, provider_id, purpose, completion, latency, *, failed: bool = False) -> None:
        super().put(key, provider_id, purpose, completion, latency, failed=failed)
        if hasattr(self, "used"):
            self.used.add(key)

    def export_used(self, path: Path) -> int:
        with self._lock:
            keys = [k for (k,) in self._db.execute("SELECT key FROM calls").fetchall() if k not in self.used]
            self._db.executemany("DELETE FROM calls WHERE key = ?", [(k,) for k in keys])
            self._db.commit()
        return self.export_json(path)


REUSE = False  # set by --reuse


def record_expansions(llm_spec: str, only: list[str] | None = None) -> None:
    for name, (behavior, limits) in EXPANSIONS.items():
        if only and name not in only:
            continue
        cache = UsedCache(None, OUT / f"{name}.json" if REUSE else None)
        llm = LLM(llm_spec, cache=cache)
        t0 = time.perf_counter()
        g = expand(behavior, llm, limits=limits)
        n = cache.export_used(OUT / f"{name}.json")
        print(f"{name}: {n} answers, {len(g.paths())} paths, {time.perf_counter() - t0:.0f} s; "
              f"{llm.stats.summary()}")


def record_generate(llm_spec: str) -> None:
    from regen.pipeline import RunSettings, generate

    name, behavior = GENERATE
    run = Path(tempfile.mkdtemp(prefix="regen-record-"))
    try:
        t0 = time.perf_counter()
        cache = UsedCache(run / "llm-cache.sqlite", OUT / f"{name}.json" if REUSE else None)
        res = generate(behavior, run, settings=RunSettings(llm=llm_spec, pictures=False),  # the main job's defaults
                       llm=LLM(llm_spec, cache=cache))
        n = cache.export_used(OUT / f"{name}.json")
        print(f"{name}: {n} answers, {res.feasible}/{len(res.outcomes)} feasible, "
              f"{time.perf_counter() - t0:.0f} s")
        for o in res.outcomes:
            print(f"    {o.folder}: {o.verdict.status}: {o.verdict.reason}")
    finally:
        shutil.rmtree(run, ignore_errors=True)


# Driving cause paths for model grounding (tests/driving/grounding/test_model.py replays them).
GROUND_PATHS = {
    "jaywalker": ("stop_abruptly", "the ego-vehicle stops abruptly while driving forward",
                  "a pedestrian jaywalks across the road in front of the ego-vehicle",
                  "adult", {"behavior": ["cross_the_road"],
                            "start_location": ["on the sidewalk ahead of the ego-vehicle"]}),
    "ambulance": ("change_lane", "the ego-vehicle changes lanes while driving forward",
                  "an ambulance with its siren on approaches from behind",
                  "ambulance", {"siren": ["on"], "behavior": ["drive_forward"],
                                "start_location": ["behind the ego-vehicle in the same lane"]}),
    "red_light": ("stop_in_intersection", "the ego-vehicle stops abruptly in an intersection",
                  "the traffic light turns red as the ego-vehicle enters the intersection",
                  "traffic_light", {"light_state": ["turns_red"]}),
}


def ground_paths() -> dict:
    from regen.core.graph import CausePath, PathEntity

    out = {}
    for key, (template, text, cause, asset, props) in GROUND_PATHS.items():
        behavior = Behavior(text=text, domain="driving", params={"ego_template": template})
        out[key] = CausePath(behavior=behavior, events=[cause, text],
                             entities=[PathEntity(asset=asset, event=cause, properties=props)])
    return out


def record_ground(llm_spec: str) -> None:
    """Ground the paths with the model; write the paths and the answers (two files)."""
    import json

    from regen.driving.grounding.model import ground_with_model

    cache = CallCache(None)
    paths = ground_paths()
    (OUT / "ground_driving_paths.json").write_text(json.dumps(
        {k: p.model_dump(mode="json") for k, p in paths.items()}, indent=1))
    for key, path in paths.items():
        # one client per path, as each replay test makes: a client stops asking for FSMs after
        # the model failed that schema once, so a shared one would leave later paths unrecorded
        llm = LLM(llm_spec, cache=cache)
        t0 = time.perf_counter()
        sc = ground_with_model(path, llm)
        print(f"ground {key}: {sc.world['grounder']} (model: {sc.world['model_parts']}), "
              f"{time.perf_counter() - t0:.0f} s; fsm {sc.fsm.as_tuples()}")
        for note in sc.fallbacks:
            print(f"    rules used: {note}")
    n = cache.export_json(OUT / "ground_driving.json")
    print(f"ground_driving: {n} answers")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("what", nargs="*", default=["expand", "generate", "ground"])
    ap.add_argument("--llm", default="local")
    ap.add_argument("--only", action="append", help="record only these expansions (repeatable)")
    ap.add_argument("--reuse", action="store_true", help="keep the committed answers of unchanged prompts")
    args = ap.parse_args()
    global REUSE
    REUSE = args.reuse
    OUT.mkdir(parents=True, exist_ok=True)
    if "expand" in args.what:
        record_expansions(args.llm, args.only)
    if "generate" in args.what:
        record_generate(args.llm)
    if "ground" in args.what:
        record_ground(args.llm)


if __name__ == "__main__":
    main()
