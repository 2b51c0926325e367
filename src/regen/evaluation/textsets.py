"""Text sets to compare: plain files for baselines, run folders for ReGen's own output.

File formats (UTF-8):
- ``.txt`` (or any other suffix): one description per line; blank lines and lines starting
  with ``#`` are ignored.
- ``.json``: a list of strings; or a list of objects with a ``"text"`` (or ``"narrative"`` /
  ``"description"``) key; or an object ``{"name": ..., "texts": [...]}``.
- ``.jsonl``: one JSON string or object (as above) per line.

A run folder contributes the texts of its scenarios (narrative, else the cause chain). Several
run folders of one behavior batch can be given separately; each is its own set. The bundled
examples are addressed as ``example:<name>`` (see ``bundled_sets()``).
"""

from __future__ import annotations

from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

from regen.errors import ConfigError
from regen.evaluation.runs import RunRecord, is_run_folder, load_run
from regen.promises.files import parse_json, read_text, text_lines

EXAMPLE_PREFIX = "example:"
_TEXT_KEYS = ("text", "narrative", "description")
_GIVE = ("give a .txt file (one text per line), a .json list of texts or a .jsonl file (one text per line), "
         "saved as UTF-8")


@dataclass
class TextSet:
    name: str
    texts: list[str]
    source: str  # file path, run folder or example name
    run: RunRecord | None = None  # set when the source is a run folder


def _item_text(item: Any, where: str) -> str:
    if isinstance(item, str):
        return item
    if isinstance(item, dict):
        for key in _TEXT_KEYS:
            if isinstance(item.get(key), str):
                return item[key]
    raise ConfigError(f"{where}: expected a string or an object with a 'text' key, got "
                      f"{type(item).__name__}")


def parse_text_set(content: str, fmt: str, where: str) -> tuple[str | None, list[str]]:
    """Parse file content in format ``fmt`` ('txt', 'json', 'jsonl') into (name, texts)."""
    name = None
    if fmt == "json":
        data = parse_json(content, where, give=_GIVE)
        if isinstance(data, dict):
            name = data.get("name") if isinstance(data.get("name"), str) else None
            data = data.get("texts")
        if not isinstance(data, list):
            raise ConfigError(f"{where}: expected a JSON list of texts or {{'texts': [...]}}")
        texts = [_item_text(x, f"{where} item {i + 1}") for i, x in enumerate(data)]
    elif fmt == "jsonl":
        texts = [_item_text(item, f"{where}, line {n}") for n, item in text_lines(content, where, give=_GIVE)]
    else:
        texts = [ln for ln in content.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
    texts = [" ".join(t.split()) for t in texts]
    return name, [t for t in texts if t]


def bundled_sets() -> dict[str, str]:
    """Names of the bundled example text sets -> their description (first comment line)."""
    out = {}
    for f in sorted((resources.files("regen.evaluation") / "data").iterdir(), key=lambda p: p.name):
        if f.name.endswith(".txt"):
            first = f.read_text(encoding="utf-8").splitlines()[0]
            out[f.name[:-4]] = first.lstrip("# ").strip()
    return out


def load_text_set(source: str | Path, name: str | None = None) -> TextSet:
    """Load one text set from a file, a run folder, or ``example:<name>``."""
    src = str(source)
    if src.startswith(EXAMPLE_PREFIX):
        key = src[len(EXAMPLE_PREFIX):]
        if key not in bundled_sets():
            raise ConfigError(f"no bundled example set {key!r}; available: "
                              f"{', '.join(bundled_sets())}")
        content = (resources.files("regen.evaluation") / "data" / f"{key}.txt").read_text("utf-8")
        _, texts = parse_text_set(content, "txt", src)
        return TextSet(name=name or key, texts=texts, source=src)
    path = Path(source)
    if is_run_folder(path):
        run = load_run(path)
        texts = [s.text for s in run.scenarios if s.text]
        return TextSet(name=name or path.name, texts=texts, source=str(path), run=run)
    if path.is_dir():
        raise ConfigError(f"{path} is a folder but not a run folder (no run.json, no scenarios/)")
    if not path.is_file():
        raise ConfigError(f"{path} does not exist (expected a text file, JSON file, run folder "
                          f"or {EXAMPLE_PREFIX}<name>)")
    content = read_text(path, what="text set", give=_GIVE)
    suffix = path.suffix.lower()
    fmt = {".json": "json", ".jsonl": "jsonl"}.get(suffix, "txt")
    file_name, texts = parse_text_set(content, fmt, str(path))
    return TextSet(name=name or file_name or path.stem, texts=texts, source=str(path))


def load_text_sets(sources: list[str | Path]) -> list[TextSet]:
    """Load several sets; repeated names get a numeric suffix so every set stays distinct."""
    out: list[TextSet] = []
    seen: dict[str, int] = {}
    for src in sources:
        ts = load_text_set(src)
        if ts.name in seen:
            seen[ts.name] += 1
            ts.name = f"{ts.name}-{seen[ts.name]}"
        else:
            seen[ts.name] = 1
        out.append(ts)
    return out
