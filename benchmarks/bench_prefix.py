"""Offline model seconds per call by purpose, with and without reusing evaluated prompt prefixes.

Usage: python benchmarks/bench_prefix.py [--run runs/demo] [--prompts FILE] [--save FILE]
                                         [--modes fresh previous kept disk] [--calls N] [--repeats R]

The prompts are the recorded ones of a finished run (the README job, ``runs/demo``, by default):
its model cache holds answers but not prompts, so the run is replayed from that cache (no model
call) and every prompt recorded; ``--save`` writes them to a file that ``--prompts`` reads back.
They are then sent to the model directly (no answer cache), in the run's order, in each mode:

- ``fresh``: every call from an empty context (every prompt token evaluated);
- ``previous``: llama-cpp-python's own reuse of what the previous call left in the context, at
  any point (the provider before prefix states);
- ``kept``: per-purpose kept states in memory (the default) in a first process (no disk states);
- ``disk``: a later process: empty memory at the start, the disk states an earlier pass wrote.

The modes take turns call by call (each keeps its own context as a saved state, loaded before
its turn and not timed), so that a change in the load of a shared machine hits them alike.
Prints per purpose and mode: seconds per call (wall, and CPU seconds of this process, which a
busy machine disturbs less), prompt tokens evaluated of all, prompt tokens/s (llama.cpp's own
prompt-eval timer, wall) and whether every answer equals the recorded one.
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from collections import defaultdict
from pathlib import Path
from typing import Any

from regen.llm.base import Sampling
from regen.llm.providers.local import LocalProvider
from regen.llm.providers.local_kv import DiskStates, KeptState, load_state, save_state
from regen.llm.providers.local_prefix import PrefixStates, capacity_bytes

MODES = ("fresh", "previous", "kept", "disk")


def record_prompts(run_dir: Path) -> list[dict[str, Any]]:
    """Replay ``run_dir`` from a copy of its model cache and record each call's purpose,
    messages, schema and answer, in order."""
    import shutil

    from regen.core.behavior import make_behavior
    from regen.llm.client import LLM
    from regen.pipeline import generate
    from regen.runfolder import RunSettings

    run = json.loads((run_dir / "run.json").read_text(encoding="utf-8"))
    calls: list[dict[str, Any]] = []

    class Recording(LLM):
        def complete(self, messages, schema, *, purpose="call", reask=False):  # type: ignore[no-untyped-def]
            got = super().complete(messages, schema, purpose=purpose, reask=reask)
            calls.append({"purpose": purpose, "messages": messages, "schema": schema,
                          "response": got[0].text})
            return got

    with tempfile.TemporaryDirectory() as tmp:
        cache = Path(tmp) / "llm-cache.sqlite"
        shutil.copy(run_dir / "llm-cache.sqlite", cache)
        settings = RunSettings(**{**run["settings"], "pictures": False})
        b = run["behavior"]
        llm = Recording(settings.llm, cache=cache, replay=True)
        generate(make_behavior(b["text"], b["domain"], **b["params"]), Path(tmp) / "run",
                 settings=settings, llm=llm, replay=True, fresh=True)
    return calls


def prompt_eval_ms(llm: Any) -> float:
    """llama.cpp's running total of prompt evaluation time [ms]."""
    import llama_cpp

    return float(llama_cpp.llama_perf_context(llm._ctx.ctx).t_p_eval_ms)  # noqa: SLF001


class LlamaCppReuse(PrefixStates):
    """The provider before prefix states: llama-cpp-python reuses whatever prefix the prompt
    shares with the context (at any point, which may change an answer), nothing is kept."""

    def _restore(self, llm: Any, tokens: list[int], purpose: str) -> None:
        pass


class Mode:
    """One way of running the calls: its kept states and its own context between turns."""

    def __init__(self, name: str, disk: Path):
        self.name = name
        capacity = 0 if name in ("fresh", "previous") else capacity_bytes()
        kind = LlamaCppReuse if name == "previous" else PrefixStates
        self.states = kind(capacity, DiskStates(disk, capacity))
        self.context: KeptState | None = None
        self.rows: list[dict[str, Any]] = []

    def turn(self, prov: LocalProvider, call: dict[str, Any], sampling: Sampling) -> None:
        """Run one call from this mode's context and record its figures."""
        llm = prov.llama()
        llm.prefix_states = self.states
        if self.context is None or self.name == "fresh":
            llm.reset()
        else:
            load_state(llm, self.context)
        t_prompt = prompt_eval_ms(llm)
        start, cpu = time.perf_counter(), time.process_time()
        got = prov.complete(call["messages"], schema=call["schema"], sampling=sampling,
                            purpose=call["purpose"])
        seconds, cpu = time.perf_counter() - start, time.process_time() - cpu
        self.context = save_state(llm)
        self.rows.append({"purpose": call["purpose"], "seconds": seconds, "cpu": cpu,
                          "prompt": got.input_tokens,
                          "evaluated": got.input_tokens - got.reused_input_tokens,
                          "prompt_s": (prompt_eval_ms(llm) - t_prompt) / 1000,
                          "same": got.text == call["response"]})


def fill_disk(prov: LocalProvider, calls: list[dict[str, Any]], disk: Path) -> None:
    """An earlier process for ``disk`` mode: the calls with one answer token each (untimed),
    which writes the prefixes calls of a purpose share."""
    mode = Mode("kept", disk)
    for call in calls:
        mode.turn(prov, call, Sampling(max_tokens=1))


def run_round(prov: LocalProvider, calls: list[dict[str, Any]], names: list[str]) -> dict[str, Mode]:
    """All calls in every mode, the modes taking turns call by call (in a rotating order)."""
    with tempfile.TemporaryDirectory() as tmp:
        first, later = Path(tmp) / "first", Path(tmp) / "later"
        if "disk" in names:
            fill_disk(prov, calls, later)
        modes = {n: Mode(n, later if n == "disk" else first / n) for n in names}
        for i, call in enumerate(calls):
            for name in names[i % len(names):] + names[: i % len(names)]:
                modes[name].turn(prov, call, Sampling())
            print(f"  call {i + 1}/{len(calls)} ({call['purpose']}): " + ", ".join(
                f"{n} {m.rows[-1]['seconds']:.1f} s ({m.rows[-1]['cpu']:.1f} CPU s, "
                f"{m.rows[-1]['evaluated']} tokens)" for n, m in modes.items()), flush=True)
    return modes


def report(results: dict[str, list[dict[str, Any]]]) -> None:
    """Print per purpose and mode: s/call, evaluated/all prompt tokens, prompt tokens/s, answers."""
    purposes = list(dict.fromkeys(r["purpose"] for rows in results.values() for r in rows))
    for purpose in [*purposes, "all"]:
        print(f"{purpose}:")
        for mode, rows in results.items():
            mine = [r for r in rows if purpose in ("all", r["purpose"])]
            total = {k: sum(r[k] for r in mine) for k in ("seconds", "cpu", "prompt", "evaluated", "prompt_s")}
            rate = total["evaluated"] / total["prompt_s"] if total["prompt_s"] > 0 else float("nan")
            same = sum(r["same"] for r in mine)
            print(f"  {mode:9s} {total['seconds'] / len(mine):6.2f} s/call, {total['cpu'] / len(mine):6.2f} "
                  f"CPU s/call ({len(mine)} calls: {total['seconds']:6.1f} s, {total['cpu']:6.1f} CPU s); "
                  f"prompt tokens evaluated {total['evaluated']:5d} of {total['prompt']:5d}, "
                  f"{rate:5.1f}/s; answers as recorded {same}/{len(mine)}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--run", type=Path, default=Path(__file__).resolve().parents[1] / "runs" / "demo")
    ap.add_argument("--prompts", type=Path, help="recorded prompts (from --save) instead of --run")
    ap.add_argument("--save", type=Path, help="write the recorded prompts here")
    ap.add_argument("--modes", nargs="+", default=list(MODES), choices=MODES)
    ap.add_argument("--calls", type=int, default=0, help="only the first N calls (0: all)")
    ap.add_argument("--repeats", type=int, default=1, help="rounds over all modes")
    ap.add_argument("--model", default="")
    args = ap.parse_args()
    if args.prompts:
        calls = json.loads(args.prompts.read_text(encoding="utf-8"))
    else:
        calls = record_prompts(args.run)
    if args.save:
        args.save.write_text(json.dumps(calls, indent=1, ensure_ascii=False), encoding="utf-8")
    calls = calls[: args.calls] if args.calls > 0 else calls
    by_purpose: dict[str, int] = defaultdict(int)
    for c in calls:
        by_purpose[c["purpose"]] += 1
    prov = LocalProvider(args.model)
    prov.llama().prefix_states = PrefixStates(0)  # nothing of the user's kept states
    c = calls[0]  # untimed: the first call pages the model's weights in
    prov.complete(c["messages"], schema=c["schema"], sampling=Sampling(max_tokens=4))
    print(f"{len(calls)} recorded calls ({dict(by_purpose)}); model {prov.model}; "
          f"kept-state budget {capacity_bytes() / 2**20:.0f} MiB; {args.repeats} round(s)")
    results: dict[str, list[dict[str, Any]]] = defaultdict(list)
    for _ in range(args.repeats):
        for name, mode in run_round(prov, calls, args.modes).items():
            results[name] += mode.rows
    report(results)


if __name__ == "__main__":
    main()
