"""Loading text sets from files and bundled examples."""

from __future__ import annotations

import json

import pytest

from regen.errors import ConfigError
from regen.evaluation.textsets import bundled_sets, load_text_set, load_text_sets


def test_txt_ignores_comments_and_blank_lines(tmp_path):
    f = tmp_path / "baseline.txt"
    f.write_text("# my baseline\nfirst  scenario\n\n  # indented comment\nsecond scenario\n")
    ts = load_text_set(f)
    assert ts.name == "baseline"
    assert ts.texts == ["first scenario", "second scenario"]


@pytest.mark.parametrize("payload, name", [
    (["a b", "c d"], "set"),
    ([{"text": "a b"}, {"narrative": "c d"}], "set"),
    ({"name": "chatscene", "texts": ["a b", {"description": "c d"}]}, "chatscene"),
])
def test_json_forms(tmp_path, payload, name):
    f = tmp_path / "set.json"
    f.write_text(json.dumps(payload))
    ts = load_text_set(f)
    assert (ts.name, ts.texts) == (name, ["a b", "c d"])


def test_jsonl(tmp_path):
    f = tmp_path / "x.jsonl"
    f.write_text('"a b"\n\n{"text": "c d"}\n')
    assert load_text_set(f).texts == ["a b", "c d"]


@pytest.mark.parametrize("suffix, content, match", [
    (".json", "{not json", "not valid JSON"),
    (".json", '{"texts": 3}', "expected a JSON list"),
    (".json", "[1, 2]", "item 1"),
    (".jsonl", '"ok"\n{bad\n', "line 2"),
])
def test_bad_files_raise_config_error(tmp_path, suffix, content, match):
    f = tmp_path / f"bad{suffix}"
    f.write_text(content)
    with pytest.raises(ConfigError, match=match):
        load_text_set(f)


def test_missing_path_and_plain_folder(tmp_path):
    with pytest.raises(ConfigError, match="does not exist"):
        load_text_set(tmp_path / "nope.txt")
    with pytest.raises(ConfigError, match="not a run folder"):
        load_text_set(tmp_path)


def test_bundled_examples_load():
    names = bundled_sets()
    assert {"zero_shot_style", "nhtsa_style", "regen_style_driving",
            "manipulation_skill_style", "manipulation_context_style"} <= set(names)
    assert "minilm_vocab" not in names
    for name in names:
        ts = load_text_set(f"example:{name}")
        assert len(ts.texts) >= 20
        assert not any(t.startswith("#") for t in ts.texts)
        assert len(set(ts.texts)) == len(ts.texts)
    with pytest.raises(ConfigError, match="available"):
        load_text_set("example:does_not_exist")


def test_repeated_names_are_made_distinct(tmp_path):
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    for d in ("a", "b"):
        (tmp_path / d / "set.txt").write_text("x y\nz w\n")
    sets = load_text_sets([tmp_path / "a" / "set.txt", tmp_path / "b" / "set.txt"])
    assert [s.name for s in sets] == ["set", "set-2"]
