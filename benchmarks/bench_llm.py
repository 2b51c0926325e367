"""Offline model on this machine: load time, and tokens/s with and without a JSON schema.

Usage: python benchmarks/bench_llm.py [--model qwen2.5-coder-1.5b] [--tokens 96] [--repeats 2]
Prints one line per figure. Calls the model directly (no cache), so figures are real.
"""

from __future__ import annotations

import argparse
import os
import time

from regen.core.base import Answer
from regen.llm.base import Sampling
from regen.llm.providers.local import LocalProvider


class Causes(Answer):
    causes: list[str]


PROMPT = ("List four plausible, different causes why a car driving forward on a city road stops abruptly. "
          'Answer as JSON: {"causes": ["...", "...", "...", "..."]}')


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--model", default="qwen2.5-coder-1.5b")
    ap.add_argument("--tokens", type=int, default=96)
    ap.add_argument("--repeats", type=int, default=2)
    args = ap.parse_args()
    prov = LocalProvider(args.model)
    t0 = time.perf_counter()
    path = prov.path()
    t1 = time.perf_counter()
    prov.llama()
    t2 = time.perf_counter()
    print(f"model: {path.name} ({path.stat().st_size / 1e9:.2f} GB), cores: {os.cpu_count()}")
    print(f"join+verify (first use, else stamp check): {t1 - t0:.2f} s")
    print(f"load time: {t2 - t1:.2f} s")
    sampling = Sampling(max_tokens=args.tokens)
    for label, schema in (("without schema", None), ("with schema", Causes.model_json_schema())):
        rates = []
        for i in range(args.repeats):
            # a distinct prompt each time so llama.cpp's prefix cache does not hide prompt cost
            msgs = [{"role": "user", "content": f"[{label} {i}] " + PROMPT}]
            s = time.perf_counter()
            c = prov.complete(msgs, schema=schema, sampling=sampling)
            el = time.perf_counter() - s
            rates.append(c.output_tokens / el)
        print(f"{label}: {sum(rates) / len(rates):.1f} tokens/s end to end "
              f"({c.output_tokens} output tokens, {c.input_tokens} prompt tokens per call, {args.repeats} calls)")


if __name__ == "__main__":
    main()
