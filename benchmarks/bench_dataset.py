"""How long ``regen dataset`` takes per sample (one CPU core): the README job replayed from its
recorded answers (``tests/data/cassettes/generate_driving.json``, no model call), then the
dataset built from that run folder, as the CLI builds it (:func:`regen.dataset.build_dataset`),
with the camera where Panda3D is installed.

Run: ``python benchmarks/bench_dataset.py [--rounds N]``. Prints the samples, the wall and CPU
seconds of each build and the seconds per sample (the first build pays the imports and the
camera engine's start; later ones are the steady figure).
"""

from __future__ import annotations

import argparse
import resource
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CASSETTE = ROOT / "tests" / "data" / "cassettes" / "generate_driving.json"
BEHAVIOR = "the ego-vehicle stops abruptly while driving forward"


def _cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=3)
    args = ap.parse_args()
    from regen.core.behavior import Behavior
    from regen.dataset import build_dataset
    from regen.llm.cache import CallCache
    from regen.pipeline import RunSettings, generate

    with tempfile.TemporaryDirectory(prefix="regen-bench-dataset-") as tmp:
        run = Path(tmp) / "run"
        run.mkdir()
        cache = CallCache(run / "llm-cache.sqlite")
        cache.import_json(CASSETTE)
        cache.close()
        generate(Behavior(text=BEHAVIOR, domain="driving"), run, settings=RunSettings(llm="local", pictures=False),
                 replay=True)
        for k in range(args.rounds):
            t0, c0 = time.perf_counter(), _cpu()
            got = build_dataset([run], Path(tmp) / f"ds{k}", formats=("parquet", "llava"))
            wall, cpu = time.perf_counter() - t0, _cpu() - c0
            per = f"{wall / got.samples:.2f} s wall, {cpu / got.samples:.2f} CPU s per sample" if got.samples else "no sample"
            cam = "no camera: " + got.camera_note if got.camera_note else "with the camera"
            print(f"build {k + 1}: {got.samples} samples, {got.qa} QA pairs, {len(got.skipped)} left out "
                  f"({cam}): {wall:.2f} s wall, {cpu:.2f} CPU s; {per}", flush=True)


if __name__ == "__main__":
    main()
