"""``regen dataset``: run folders in, a vision-language-action dataset out (:func:`build_dataset`).

Everything is built in a temporary folder beside ``out`` and moved into place at the end, so a
crash leaves no half dataset. The files are deterministic: rows sorted by sample id, QA rows by
sample, layer and question, JSON with sorted keys, Parquet written by pyarrow with fixed
settings, PNGs with a fixed zlib level; nothing holds a time stamp or an absolute path.
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from regen import media
from regen.core.io import atomic_write_bytes
from regen.dataset.labels import LABELS, LeftOut
from regen.dataset.qa import HORIZON, LAYERS
from regen.dataset.samples import (
    CAMERA_SIZE,
    FRAME_OFFSETS,
    Sample,
    Skipped,
    build,
    camera,
    candidates,
    check,
    simulate_variant,
)
from regen.errors import ConfigError, DependencyNotInstalled

FORMATS = ("parquet", "llava")
SAMPLES, QA_FILE, LLAVA, CARD, IMAGES = "samples.parquet", "qa.parquet", "llava.json", "README.md", "images"
OWN = frozenset({SAMPLES, QA_FILE, LLAVA, CARD, IMAGES})
PROBE_PREFIX = "probe-"  # regen probe's default result folders: kept when the dataset is rebuilt
PNG_ZLIB = 6  # zlib level of every picture: the same pixels give the same bytes
PARQUET = {"compression": "zstd", "compression_level": 3, "version": "2.6", "use_dictionary": False,
           "write_statistics": False, "data_page_size": 1 << 20}


@dataclass
class DatasetResult:
    out: Path
    samples: int
    qa: int
    skipped: list[Skipped] = field(default_factory=list)
    camera_note: str = ""
    files: list[str] = field(default_factory=list)

    @property
    def left_out(self) -> Counter[str]:
        return Counter(s.reason for s in self.skipped)


def pyarrow_modules():
    """(pyarrow, pyarrow.parquet); DependencyNotInstalled naming the extra when missing."""
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError as exc:
        raise DependencyNotInstalled("pyarrow", "dataset", "the Parquet files of regen dataset and regen probe"
                                     ) from exc
    return pa, pq


def _schema(pa: Any, frames: int) -> Any:
    state = pa.struct([("key", pa.string()), ("value", pa.string())])
    entity = pa.struct([("name", pa.string()), ("kind", pa.string()), ("asset", pa.string()),
                        ("x", pa.float64()), ("y", pa.float64()), ("heading", pa.float64()),
                        ("speed", pa.float64()), ("length", pa.float64()), ("width", pa.float64()),
                        ("height", pa.float64()), ("states", pa.list_(state))])
    frame = pa.struct([("t", pa.float64()), ("step", pa.int64()), ("entities", pa.list_(entity))])
    cols = [("sample_id", pa.string()), ("pair_id", pa.string()), ("source", pa.string()),
            ("run", pa.string()), ("scenario", pa.string()), ("scenario_id", pa.string()),
            ("variant", pa.int64()), ("edits", pa.string()), ("behavior", pa.string()),
            ("ego_template", pa.string()), ("map", pa.string()), ("decision_time", pa.float64()),
            ("decision_stage", pa.int64()), ("frame_times", pa.list_(pa.float64()))]
    cols += [(f"camera_image_{k}", pa.string()) for k in range(frames)]
    cols += [(f"bev_image_{k}", pa.string()) for k in range(frames)]
    cols += [("ego_speed", pa.float64()), ("instruction", pa.string()), ("action", pa.string()),
             ("action_meaning", pa.string()), ("action_evidence", pa.string()), ("explanation", pa.string()),
             ("cause_chain", pa.list_(pa.string())), ("narrative", pa.string()),
             ("cause_entities", pa.list_(pa.string())), ("verdict_status", pa.string()),
             ("causal_status", pa.string()), ("privileged", pa.list_(frame))]
    return pa.schema(cols)


QA_COLUMNS = ("qa_id", "sample_id", "pair_id", "layer", "question", "answer", "computed_from", "options", "key")


def _qa_schema(pa: Any) -> Any:
    """Text columns, then the multiple-choice ``options`` (a list) and ``key`` (None: not scored)."""
    return pa.schema([(c, pa.string()) for c in QA_COLUMNS[:-2]]
                     + [("options", pa.list_(pa.string())), ("key", pa.string())])


def _write_parquet(path: Path, rows: list[dict[str, Any]], schema: Any) -> None:
    pa, pq = pyarrow_modules()
    table = pa.Table.from_pylist(rows, schema=schema)
    pq.write_table(table, path, **PARQUET)


def _qa_rows(samples: list[Sample]) -> list[dict[str, Any]]:
    rows = []
    for s in samples:
        order = sorted(s.qa, key=lambda q: LAYERS.index(q.layer))  # stable: questions keep their order
        for k, q in enumerate(order):
            rows.append({"qa_id": f"{s.row['sample_id']}-{k:02d}", "sample_id": s.row["sample_id"],
                         "pair_id": s.row["pair_id"], "layer": q.layer, "question": q.question,
                         "answer": q.answer, "computed_from": q.source, "options": list(q.options),
                         "key": q.key})
    return rows


def _llava(samples: list[Sample]) -> list[dict[str, Any]]:
    out = []
    for s in samples:
        r = s.row
        keys = sorted(k for k in r if k.startswith("camera_image_") and r[k]) or \
            sorted(k for k in r if k.startswith("bev_image_"))
        images = [r[k] for k in keys]
        turns = [{"from": "human", "value": "<image>\n" * len(images) + r["instruction"]},
                 {"from": "gpt", "value": f"{r['action']}. {r['explanation']}"}]
        for q in sorted(s.qa, key=lambda q: LAYERS.index(q.layer)):
            turns += [{"from": "human", "value": q.question}, {"from": "gpt", "value": q.answer}]
        out.append({"id": r["sample_id"], "pair_id": r["pair_id"], "image": images, "conversations": turns})
    return out


def _json_bytes(value: Any) -> bytes:
    return (json.dumps(value, indent=1, sort_keys=True, ensure_ascii=False) + "\n").encode("utf-8")


def _refuse_foreign(out: Path) -> None:
    """A folder that holds anything but a dataset of ours is never replaced."""
    if out.exists() and not out.is_dir():
        raise ConfigError(f"--out {out} is a file; give a folder for the dataset")
    if out.is_dir():
        foreign = sorted(p.name for p in out.iterdir()
                         if p.name not in OWN and not (p.is_dir() and p.name.startswith(PROBE_PREFIX)))
        if foreign:
            raise ConfigError(f"--out {out} holds files that are not a regen dataset ({', '.join(foreign[:5])}); "
                              "give an empty or new folder")


def _move_into_place(tmp: Path, out: Path) -> None:
    old = None
    if out.exists():
        # regen probe's folders move into the new dataset: their model caches answer again the
        # questions that did not change (a rerun of the probe rewrites their scores)
        for p in sorted(out.iterdir()):
            if p.is_dir() and p.name.startswith(PROBE_PREFIX):
                os.replace(p, tmp / p.name)
        old = Path(tempfile.mkdtemp(prefix=f".{out.name}.old-", dir=out.parent))
        os.replace(out, old / "dataset")
    os.replace(tmp, out)
    if old is not None:
        shutil.rmtree(old, ignore_errors=True)


def build_dataset(runs: list[str | Path], out: str | Path, *, formats: tuple[str, ...] = ("parquet",),
                  variants: bool = True, on_event: Callable[[dict[str, Any]], None] | None = None) -> DatasetResult:
    """Build the dataset of ``runs`` (driving run folders) into ``out``: ``samples.parquet``,
    ``qa.parquet``, ``images/``, ``README.md`` and, with 'llava' in ``formats``, ``llava.json``.
    ``variants``: also simulate the test variants ``regen test`` recorded (about a second each).
    ``on_event`` gets the progress events of :mod:`regen.progress`."""
    emit = on_event or (lambda ev: None)
    bad = [f for f in formats if f not in FORMATS]
    if bad or not formats:
        raise ConfigError(f"--format must be parquet or llava, not {', '.join(bad) or 'nothing'}")
    if not runs:
        raise ConfigError("give at least one run folder (RUN_DIR), e.g. regen dataset runs/stop --out datasets/stop")
    out = Path(out)
    _refuse_foreign(out)
    pa, _ = pyarrow_modules()
    emit({"event": "stage", "stage": "reading runs"})
    found = [c for r in runs for c in candidates(r, variants=variants)]
    cam, note = camera()
    emit({"event": "paths", "total": len(found), "what": "candidate scenario(s) to turn into samples",
          "kept": "samples"})
    emit({"event": "stage", "stage": "building samples"})
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.tmp-", dir=out.parent))
    try:
        samples, skipped = _samples(found, cam, tmp, emit)
        samples.sort(key=lambda s: s.row["sample_id"])
        skipped.sort(key=lambda s: (s.sample_id, s.reason))
        written = [CARD]
        # the tables are always written (scripts read them); llava.json comes beside them
        _write_parquet(tmp / SAMPLES, [s.row for s in samples], _schema(pa, len(FRAME_OFFSETS)))
        _write_parquet(tmp / QA_FILE, _qa_rows(samples), _qa_schema(pa))
        written += [SAMPLES, QA_FILE]
        if "llava" in formats:
            atomic_write_bytes(tmp / LLAVA, _json_bytes(_llava(samples)))
            written.append(LLAVA)
        result = DatasetResult(out=out, samples=len(samples), qa=sum(len(s.qa) for s in samples),
                               skipped=skipped, camera_note=note, files=sorted(written))
        from regen.dataset.card import card

        atomic_write_bytes(tmp / CARD, card(result, samples, [str(Path(r).name) for r in runs]).encode())
        emit({"event": "stage", "stage": "moving into place"})
        _move_into_place(tmp, out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return result


def _samples(found: list[Any], cam: Any, tmp: Path, emit: Callable[[dict[str, Any]], None]
             ) -> tuple[list[Sample], list[Skipped]]:
    samples: list[Sample] = []
    skipped: list[Skipped] = []
    ids: set[str] = set()
    for c in found:
        emit({"event": "simulating" if c.source == "variant" else "drawing", "name": c.sample_id})
        try:
            if c.sample_id in ids:
                raise LeftOut("duplicate", "the same scenario given twice")
            if c.source == "variant" and not c.problem and c.trace is None:
                simulate_variant(c)
            lab = check(c)
            sample = build(c, lab, cam)
        except LeftOut as why:
            skipped.append(Skipped(c.sample_id, c.source, why.reason, why.detail))
            emit({"event": "scenario_done", "feasible": False, "name": c.sample_id,
                  "status": f"left out ({why.reason})"})
            continue
        ids.add(c.sample_id)
        for rel, img in sorted(sample.images.items()):
            path = tmp / rel
            path.parent.mkdir(parents=True, exist_ok=True)
            media.write_png(path, img, compress_level=PNG_ZLIB)
        sample.images = {}
        samples.append(sample)
        emit({"event": "scenario_done", "feasible": True, "name": c.sample_id,
              "status": f"sample, {sample.row['action']}"})
    return samples, skipped


__all__ = ["CAMERA_SIZE", "DatasetResult", "FORMATS", "HORIZON", "LABELS", "QA_COLUMNS", "build_dataset"]
