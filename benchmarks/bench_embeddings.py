"""Benchmark of the evaluation metrics: embedding throughput and Self-BLEU time.

Run: ``python benchmarks/bench_embeddings.py [--sentences 512] [--reference MODEL_DIR]``

Prints the encoder load time [s], sentences per second of all-MiniLM-L6-v2 (int8 ONNX) on the
bundled example sets, and the time of one Self-BLEU over 30 texts. With ``--reference`` pointing
at a sentence-transformers folder of all-MiniLM-L6-v2 (``model.safetensors``, ``vocab.txt``), it
also runs an fp32 numpy forward pass of the original weights and prints how closely the int8
vectors agree (no torch needed).
"""

from __future__ import annotations

import argparse
import json
import math
import struct
import time
from pathlib import Path

import numpy as np

from regen.embeddings import SentenceEncoder, mean_pool_normalize
from regen.evaluation.diversity import self_bleu
from regen.evaluation.textsets import bundled_sets, load_text_set


def _corpus(count: int) -> list[str]:
    texts = [t for name in bundled_sets() for t in load_text_set(f"example:{name}").texts]
    return [texts[i % len(texts)] for i in range(count)]


def _reference_embeddings(model_dir: Path, texts: list[str], encoder: SentenceEncoder) -> np.ndarray:
    """fp32 BERT forward pass of the original all-MiniLM-L6-v2 weights in numpy."""
    raw = (model_dir / "model.safetensors").read_bytes()
    n = struct.unpack("<Q", raw[:8])[0]
    header = json.loads(raw[8:8 + n])
    w = {}
    for k, v in header.items():
        if k == "__metadata__" or v["dtype"] != "F32":
            continue
        a, b = v["data_offsets"]
        w[k] = np.frombuffer(raw[8 + n + a: 8 + n + b], dtype=np.float32).reshape(v["shape"])
    erf = np.vectorize(math.erf)

    def ln(x, p):
        mu = x.mean(-1, keepdims=True)
        var = ((x - mu) ** 2).mean(-1, keepdims=True)
        return (x - mu) / np.sqrt(var + 1e-12) * w[p + ".weight"] + w[p + ".bias"]

    def lin(x, p):
        return x @ w[p + ".weight"].T + w[p + ".bias"]

    enc = encoder._tokenizer.encode_batch(texts)
    ids = np.array([e.ids for e in enc])
    mask = np.array([e.attention_mask for e in enc])
    bsz, t = ids.shape
    x = (w["embeddings.word_embeddings.weight"][ids] + w["embeddings.position_embeddings.weight"][:t]
         + w["embeddings.token_type_embeddings.weight"][0])
    x = ln(x, "embeddings.LayerNorm")
    bias = (1 - mask[:, None, None, :]) * -1e9
    for layer in range(6):
        p = f"encoder.layer.{layer}."
        q, k, v = (lin(x, p + f"attention.self.{m}").reshape(bsz, t, 12, 32).transpose(0, 2, 1, 3)
                   for m in ("query", "key", "value"))
        s = q @ k.transpose(0, 1, 3, 2) / math.sqrt(32) + bias
        s = np.exp(s - s.max(-1, keepdims=True))
        s /= s.sum(-1, keepdims=True)
        a = (s @ v).transpose(0, 2, 1, 3).reshape(bsz, t, 384)
        x = ln(x + lin(a, p + "attention.output.dense"), p + "attention.output.LayerNorm")
        h = lin(x, p + "intermediate.dense")
        h = 0.5 * h * (1 + erf(h / math.sqrt(2)))
        x = ln(x + lin(h, p + "output.dense"), p + "output.LayerNorm")
    return mean_pool_normalize(x, mask)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--sentences", type=int, default=512)
    ap.add_argument("--reference", type=Path, default=None)
    args = ap.parse_args()

    t0 = time.perf_counter()
    enc = SentenceEncoder()
    load = time.perf_counter() - t0
    texts = _corpus(args.sentences)
    enc.encode(texts[:8])  # warm-up
    t0 = time.perf_counter()
    enc.encode(texts)
    dt = time.perf_counter() - t0
    print(f"encoder load: {load:.2f} s")
    print(f"embeddings: {len(texts)} sentences in {dt:.2f} s = {len(texts) / dt:.0f} sentences/s")
    sample = load_text_set("example:zero_shot_style").texts[:30]
    t0 = time.perf_counter()
    self_bleu(sample)
    print(f"Self-BLEU over {len(sample)} texts: {time.perf_counter() - t0:.3f} s")
    if args.reference:
        probe = texts[:24]
        ref = _reference_embeddings(args.reference, probe, enc)
        got = enc.encode(probe)
        cos = (ref * got).sum(1)
        sim_gap = np.abs(ref @ ref.T - got @ got.T).max()
        print(f"int8 vs fp32 reference: per-sentence cosine min {cos.min():.4f}, mean {cos.mean():.4f}; "
              f"max |similarity difference| {sim_gap:.4f}")


if __name__ == "__main__":
    main()
