"""The batch spec is checked whole before anything runs: each refusal names the entry and says
what to do; the shipped example spec plans."""

from __future__ import annotations

from pathlib import Path

import pytest

from regen.batch.spec import plan, read_spec
from regen.errors import ConfigError
from regen.pipeline.request import behavior_to_generate, export_options

ROOT = Path(__file__).resolve().parents[2]
STOP = "the ego-vehicle stops abruptly while driving forward"


def _write(tmp_path: Path, text: str) -> Path:
    p = tmp_path / "spec.yaml"
    p.write_text(text)
    return p


def _plan(path: Path):
    spec, _ = read_spec(path)
    return plan(spec, behavior_to_generate, export_options, base=path.parent)


def test_the_example_spec_plans_nine_behaviors_with_their_settings() -> None:
    planned = _plan(ROOT / "examples" / "batch.yaml")
    assert [p.behavior.domain for p in planned].count("driving") == 6
    assert [p.behavior.domain for p in planned].count("manipulation") == 3
    assert len({p.key() for p in planned}) == 9
    assert all(p.settings.max_scenarios == 2 for p in planned)
    templates = {p.behavior.params.get("ego_template") for p in planned if p.behavior.domain == "driving"}
    assert len(templates) == 6


def test_an_entry_takes_the_generate_settings_under_their_option_names(tmp_path) -> None:
    (p,) = _plan(_write(tmp_path, f"""behaviors:
  - text: {STOP}
    domain: driving
    scenarios: 5
    cause: a child runs across the road
    depth: 1
    seed: 7
    pictures: false
    no_ego_story: true
"""))
    s = p.settings
    assert (s.max_scenarios, s.depth, s.seed, s.pictures) == (5, 1, 7, False)
    assert s.forced_causes == ["a child runs across the road"]
    assert s.export_options == {"ego_story": False}


@pytest.mark.parametrize("text, says", [
    ("behaviors: []\n", "non-empty list"),
    ("- text: x\n", "YAML mapping with a 'behaviors:' list"),
    ("behaviors:\n  - text: x\n    domain: driving\nextra: 1\n", "unknown key(s) extra"),
    (f"behaviors:\n  - text: {STOP}\n    domain: driving\n    scenario: 3\n",
     f"behaviors entry 1 ('{STOP}'): unknown key(s) scenario"),
    (f"behaviors:\n  - text: {STOP}\n    domain: driving\n  - text: the robot opens the door\n    domain: kitchen\n",
     "behaviors entry 2 ('the robot opens the door')"),
    (f"behaviors:\n  - text: {STOP}\n    domain: driving\n    scenarios: 0\n", "scenarios"),
    ("behaviors:\n  - text: [unclosed\n", "not valid YAML"),
])
def test_a_bad_spec_is_refused_naming_what_is_wrong(tmp_path, text, says) -> None:
    with pytest.raises(ConfigError) as exc:
        _plan(_write(tmp_path, text))
    assert says in str(exc.value)


def test_a_behavior_given_twice_is_refused_naming_both_entries(tmp_path) -> None:
    path = _write(tmp_path, f"""behaviors:
  - text: {STOP}
    domain: driving
    scenarios: 2
  - text: {STOP.upper()}
    domain: driving
    scenarios: 4
""")
    with pytest.raises(ConfigError, match="behaviors entry 2 .* repeats behaviors entry 1"):
        _plan(path)


def test_the_same_text_with_another_ego_or_other_causes_is_another_request(tmp_path) -> None:
    planned = _plan(_write(tmp_path, f"""behaviors:
  - text: {STOP}
    domain: driving
    ego: stop_abruptly
  - text: {STOP}
    domain: driving
    ego: slow_down
  - text: {STOP}
    domain: driving
    ego: stop_abruptly
    cause: a child runs across the road
"""))
    assert len(planned) == 3


def test_a_missing_spec_file_says_what_to_give(tmp_path) -> None:
    with pytest.raises(ConfigError, match="no batch spec at .*behaviors"):
        read_spec(tmp_path / "nope.yaml")


def test_a_relative_trajectory_is_read_beside_the_spec(tmp_path) -> None:
    path = _write(tmp_path, "behaviors:\n  - domain: driving\n    ego_trajectory: drive.csv\n")
    with pytest.raises(ConfigError) as exc:
        _plan(path)
    assert "behaviors entry 1" in str(exc.value) and str(tmp_path) in str(exc.value)
