"""Offline model on this machine: load time, and tokens/s with and without a JSON schema (with
the provider's grammar-first greedy sampler, and with llama-cpp-python's own sampler chain).

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
    llama = type(prov.llama())
    ours = llama.__dict__["_init_sampler"]
    causes = Causes.model_json_schema()
    for label, schema, init in (("without schema", None, ours), ("with schema", causes, ours),
                                ("with schema, llama-cpp's own chain", causes, None)):
        if init is None:  # the base class's sampler chain: the grammar over the whole vocabulary
            del llama._init_sampler
        else:
            llama._init_sampler = init
        rates = []
        for i in range(args.repeats):
            # the same prompts for every variant, each evaluated from an empty context, so that
            # llama.cpp's prefix reuse hides no prompt cost and the variants decode the same task
            msgs = [{"role": "user", "content": f"[{i}] " + PROMPT}]
            prov.llama().reset()
            s = time.perf_counter()
            c = prov.complete(msgs, schema=schema, sampling=sampling)
            el = time.perf_counter() - s
            rates.append(c.output_tokens / el)
        print(f"{label}: {sum(rates) / len(rates):.1f} tokens/s end to end "
              f"({c.output_tokens} output tokens, {c.input_tokens} prompt tokens per call, {args.repeats} calls)")


if __name__ == "__main__":
    main()
