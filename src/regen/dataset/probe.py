"""``regen probe DATASET``: ask a model each multiple-choice question of a dataset built by
``regen dataset`` and score its answer against the simulation's key, by exact match.

Each question is asked with its options and the JSON schema ``{"answer": one of the options}``,
through the model layer (cached and replayed like any call, purpose ``probe``). Its inputs: the
sample's key frames as PNG pictures (camera where the dataset has them, else bird's-eye) when
the provider accepts images and ``text_only`` is off; the per-frame privileged information as
text with ``privileged``, and always when no picture is shown (a text-only probe without it
would be guessing). Scores, the planning confusion matrix and the counterfactual flips:
:mod:`regen.dataset.probe_score`.
"""

from __future__ import annotations

import re
import threading
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, Literal

from pydantic import BaseModel, BeforeValidator, ConfigDict, create_model

from regen.dataset.labels import LABELS
from regen.dataset.qa import LAYERS
from regen.dataset.write import QA_FILE, SAMPLES, pyarrow_modules
from regen.errors import ConfigError, MalformedAnswerError
from regen.llm import LLM, Provider
from regen.llm.base import Message, image_message
from regen.templates import render

if TYPE_CHECKING:
    from regen.dataset.probe_score import Score

PURPOSE = "probe"
DOMAIN = "driving"  # of a dataset whose samples name none (regen dataset builds driving datasets)
CACHE = "llm-cache.sqlite"  # the model's answers, beside the results (a rerun replays them)
NOT_A_DATASET = ("{path} is not a regen dataset (no samples.parquet and qa.parquet): give the --out folder "
                 "of 'regen dataset', e.g. regen probe datasets/stop --llm local")
NO_OPTIONS = ("{path}/qa.parquet has no options and key columns (built before regen probe existed): "
              "build it again with regen dataset RUN_DIR... --out {path}")
TEXT_ONLY_NOTE = ("text-only: the {name} model reads no images; questions asked with the privileged "
                  "information as text")
ASKED_TEXT_NOTE = "text-only (--text-only): questions asked with the privileged information as text"


@dataclass(frozen=True)
class Question:
    """One row of qa.parquet."""

    qa_id: str
    sample_id: str
    pair_id: str
    layer: str
    question: str
    options: tuple[str, ...]
    key: str | None  # None: not scored


@dataclass(frozen=True)
class SampleInfo:
    """What the probe needs of one row of samples.parquet."""

    sample_id: str
    pair_id: str
    behavior: str
    cause: str  # the cause entities' asset categories ('pedestrians', 'traffic+vehicles', 'none')
    frame_times: tuple[float, ...]  # [s]
    pictures: tuple[str, ...]  # paths relative to the dataset: camera where present, else bird's-eye
    view: str  # 'forward camera' or "bird's-eye view"
    privileged: tuple[dict[str, Any], ...]  # per frame: t, step, entities


@dataclass
class Dataset:
    path: Path
    samples: dict[str, SampleInfo]
    questions: list[Question]  # in qa_id order


@dataclass(frozen=True)
class Mode:
    """How the questions are asked."""

    images: bool  # the key frames are shown as pictures
    privileged: bool  # the per-frame privileged information is given as text
    note: str = ""  # why the probe is text-only ('' when it shows pictures)

    @property
    def asked(self) -> str:
        return "images" if self.images else "text"


@dataclass
class Asked:
    """One question of a probe (a row of probe.json)."""

    qa_id: str
    sample_id: str
    layer: str
    key: str | None
    asked: str | None = None  # 'images' | 'text'; None: not asked (not scored, or past --limit)
    privileged: bool = False
    answer: str | None = None  # None: not asked, or no valid answer after the re-asks
    correct: bool | None = None  # None: not asked

    def as_dict(self) -> dict[str, Any]:
        return dict(vars(self))


@dataclass
class ProbeResult:
    dataset: Dataset
    provider: str  # the provider's id
    mode: Mode
    layers: tuple[str, ...]
    rows: list[Asked] = field(default_factory=list)
    out: Path | None = None
    files: list[str] = field(default_factory=list)  # written into out
    score: Score | None = None


def parse_layers(given: str | Sequence[str] | None) -> tuple[str, ...]:
    """The layers of ``--layers`` ('perception,planning', repeatable), in :data:`LAYERS` order;
    ConfigError (exit 2) naming the layers for an unknown one."""
    if not given:
        return LAYERS
    parts = [given] if isinstance(given, str) else list(given)
    names = [p.strip() for part in parts for p in part.split(",") if p.strip()]
    bad = [n for n in names if n not in LAYERS]
    if bad or not names:
        given_text = ", ".join(repr(n) for n in bad) or "nothing"
        raise ConfigError(f"--layers takes {','.join(LAYERS)} (comma-separated), not {given_text}")
    return tuple(layer for layer in LAYERS if layer in names)


def _category(domain: str, assets: list[str]) -> str:
    """The asset categories of the cause entities (the domain's asset database), joined by '+'."""
    from regen.assets.database import database_of

    db = database_of(domain)
    cats = sorted({db.category_of(a) or a for a in assets})
    return "+".join(cats) or "none"


def _sample(row: dict[str, Any]) -> SampleInfo:
    frames = tuple(row.get("privileged") or ())
    assets = {e["name"]: e["asset"] for e in (frames[-1]["entities"] if frames else [])}
    n = len(row.get("frame_times") or ())
    cams = [row.get(f"camera_image_{k}") for k in range(n)]
    pictures = cams if cams and all(cams) else [row.get(f"bev_image_{k}") for k in range(n)]
    return SampleInfo(sample_id=row["sample_id"], pair_id=row["pair_id"], behavior=row.get("behavior") or "",
                      cause=_category(row.get("domain") or DOMAIN,
                                      [assets.get(e, e) for e in row.get("cause_entities") or []]),
                      frame_times=tuple(float(t) for t in row.get("frame_times") or ()),
                      pictures=tuple(str(p) for p in pictures if p),
                      view="forward camera" if cams and all(cams) else "bird's-eye view, the ego in the middle",
                      privileged=frames)


def read_dataset(path: str | Path) -> Dataset:
    """A dataset folder of ``regen dataset``; ConfigError (exit 2) saying what to pass otherwise."""
    folder = Path(path)
    if not (folder / SAMPLES).is_file() or not (folder / QA_FILE).is_file():
        raise ConfigError(NOT_A_DATASET.format(path=path))
    _, pq = pyarrow_modules()
    try:
        samples = pq.read_table(folder / SAMPLES).to_pylist()
        qa = pq.read_table(folder / QA_FILE)
    except (OSError, ValueError) as exc:  # pyarrow.ArrowInvalid is a ValueError
        raise ConfigError(f"{path}: the dataset's tables cannot be read ({exc}); build it again with "
                          "regen dataset") from None
    if not {"options", "key"} <= set(qa.column_names):
        raise ConfigError(NO_OPTIONS.format(path=path))
    by_id = {r["sample_id"]: _sample(r) for r in samples}
    questions = [Question(qa_id=r["qa_id"], sample_id=r["sample_id"], pair_id=r["pair_id"], layer=r["layer"],
                          question=r["question"], options=tuple(r["options"] or ()), key=r["key"])
                 for r in qa.to_pylist() if r["sample_id"] in by_id]
    questions.sort(key=lambda q: q.qa_id)
    return Dataset(path=folder, samples=by_id, questions=questions)


def mode_for(provider: Provider, *, text_only: bool = False, privileged: bool = False) -> Mode:
    """Pictures when the provider reads them and ``text_only`` is off; without pictures the
    privileged information is always given."""
    if not provider.accepts_images:
        return Mode(images=False, privileged=True, note=TEXT_ONLY_NOTE.format(name=provider.name))
    if text_only:
        return Mode(images=False, privileged=True, note=ASKED_TEXT_NOTE)
    return Mode(images=True, privileged=privileged)


def _number(v: Any) -> str:
    return f"{float(v):.1f}" if isinstance(v, int | float) else str(v)


def privileged_text(frames: Sequence[dict[str, Any]]) -> str:
    """The per-frame privileged information, one line an entity: 'ego (ego ego): x 139.6, y -1.8,
    heading 0.00, speed 6.6, 4.6 x 1.9; brake_lights on, lane 0.0'."""
    lines = []
    for f in frames:
        lines.append(f"t = {float(f['t']):.1f} s:")
        for e in f["entities"]:
            states = ", ".join(f"{s['key']} {s['value']}" for s in e.get("states") or [] if s.get("value") is not None)
            lines.append(f"  {e['name']} ({e['kind']} {e['asset']}): x {_number(e['x'])}, y {_number(e['y'])}, "
                         f"heading {float(e['heading']):.2f}, speed {_number(e['speed'])}, "
                         f"{_number(e['length'])} x {_number(e['width'])}" + (f"; {states}" if states else ""))
    return "\n".join(lines)


def _ego(frames: Sequence[dict[str, Any]]) -> str:
    ents = frames[-1]["entities"] if frames else []
    return next((e["name"] for e in ents if e["kind"] in ("ego", "robot")), "ego")


def message(data: Dataset, q: Question, mode: Mode) -> Message:
    """The user message of one question: its text (rendered from ``prompts/probe.j2``) and, in
    a probe with pictures, the sample's key frames."""
    s = data.samples[q.sample_id]
    text = render("regen.dataset", "probe", images=len(s.pictures) if mode.images else 0,
                  times=", ".join(f"{t:.1f}" for t in s.frame_times), view=s.view,
                  privileged=privileged_text(s.privileged) if mode.privileged else "", ego=_ego(s.privileged),
                  question=q.question, options=list(q.options), meanings=LABELS)
    if not mode.images:
        return {"role": "user", "content": text}
    pngs = []
    for rel in s.pictures:
        try:
            pngs.append((data.path / rel).read_bytes())
        except OSError as exc:
            raise ConfigError(f"{data.path / rel}: a picture of sample {q.sample_id} cannot be read ({exc.strerror}); "
                              "build the dataset again, or probe with --text-only") from None
    return image_message(text, pngs)


def _fold(text: str) -> str:
    return " ".join(text.split()).strip(" .'\"`").casefold()


@lru_cache(maxsize=64)
def answer_schema(options: tuple[str, ...]) -> type[BaseModel]:
    """``{"answer": one of options}``; an answer that differs from an option only in case,
    spacing or a closing full stop is read as that option (the scoring stays exact)."""
    folded = {_fold(o): o for o in options}

    def pick(value: Any) -> Any:
        return folded.get(_fold(value), value) if isinstance(value, str) else value

    field_type = Annotated[Literal[options], BeforeValidator(pick)]  # type: ignore[valid-type]
    return create_model("ProbeAnswer", __config__=ConfigDict(extra="forbid"), answer=(field_type, ...))


def ask(llm: LLM, data: Dataset, q: Question, mode: Mode) -> Asked:
    """Ask one question; a model that gives no valid option after the re-asks is wrong."""
    row = Asked(qa_id=q.qa_id, sample_id=q.sample_id, layer=q.layer, key=q.key, asked=mode.asked,
                privileged=mode.privileged)
    system = render("regen.dataset", "probe_system")
    try:
        got = llm.ask([message(data, q, mode)], answer_schema(q.options), purpose=PURPOSE, system=system)
    except MalformedAnswerError:
        row.correct = False
        return row
    row.answer = got.value.answer  # type: ignore[attr-defined]
    row.correct = row.answer == q.key
    return row


def default_out(dataset: str | Path, provider: str) -> Path:
    """``DATASET/probe-<provider>`` ('openai:gpt-4o' -> probe-openai-gpt-4o)."""
    return Path(dataset) / ("probe-" + (re.sub(r"[^A-Za-z0-9._-]+", "-", provider).strip("-.") or "model"))


def probe_dataset(dataset: str | Path, llm: LLM | Provider | str, *, out: str | Path | None = None,
                  text_only: bool = False, privileged: bool = False, layers: Sequence[str] | str | None = None,
                  limit: int | None = None, replay: bool = False,
                  on_answer: Callable[[int, int, Asked], None] | None = None) -> ProbeResult:
    """Ask ``llm`` each scored question of ``dataset`` (the first ``limit`` of the chosen
    ``layers``) and score the answers; write ``probe.json``, ``report.md`` and the planning
    confusion matrix ``confusion_planning.png`` into ``out`` (default ``DATASET/probe-<provider>``).
    A provider or name given instead of a client gets one caching in ``out/llm-cache.sqlite``.
    ``on_answer(done, total, asked)`` is called after each question is answered (progress)."""
    chosen = parse_layers(layers)
    if limit is not None and limit < 1:
        raise ConfigError(f"--limit must be 1 or more, not {limit}")
    data = read_dataset(dataset)
    if isinstance(llm, LLM):
        spec = llm.provider.id
    else:
        spec = llm if isinstance(llm, str) else llm.id
    out_dir = Path(out) if out is not None else default_out(dataset, spec)
    if out_dir.exists() and not out_dir.is_dir():
        raise ConfigError(f"--out {out_dir} is a file; give a folder for the probe's results")
    if isinstance(llm, LLM):
        return _probe(data, llm, out_dir, chosen, text_only, privileged, limit, on_answer)
    out_dir.mkdir(parents=True, exist_ok=True)
    client = LLM(llm, cache=out_dir / CACHE, replay=replay)
    try:
        return _probe(data, client, out_dir, chosen, text_only, privileged, limit, on_answer)
    finally:
        client.cache.close()


def _probe(data: Dataset, llm: LLM, out: Path, layers: tuple[str, ...], text_only: bool, privileged: bool,
           limit: int | None, on_answer: Callable[[int, int, Asked], None] | None = None) -> ProbeResult:
    from regen.dataset.probe_score import write_results

    mode = mode_for(llm.provider, text_only=text_only, privileged=privileged)
    rows = [Asked(qa_id=q.qa_id, sample_id=q.sample_id, layer=q.layer, key=q.key)
            for q in data.questions if q.layer in layers]
    todo = [q for q in data.questions if q.layer in layers and q.key is not None and q.key in q.options]
    todo = todo[:limit] if limit is not None else todo
    lock, done = threading.Lock(), [0]

    def one(q: Question) -> Asked:
        got = ask(llm, data, q, mode)
        if on_answer is not None:
            with lock:  # remote providers answer concurrently
                done[0] += 1
                on_answer(done[0], len(todo), got)
        return got

    answered = {a.qa_id: a for a in llm.map(one, todo)}
    result = ProbeResult(dataset=data, provider=llm.provider.id, mode=mode, layers=layers,
                         rows=[answered.get(r.qa_id, r) for r in rows], out=out)
    write_results(result)
    return result


__all__ = ["ASKED_TEXT_NOTE", "Asked", "Dataset", "Mode", "ProbeResult", "Question", "SampleInfo", "TEXT_ONLY_NOTE",
           "answer_schema", "ask", "default_out", "message", "mode_for", "parse_layers", "privileged_text",
           "probe_dataset", "read_dataset"]
