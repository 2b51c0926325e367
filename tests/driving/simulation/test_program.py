"""Free text in the exported Scenic program: any Unicode a narrative holds survives, as valid UTF-8."""

from __future__ import annotations

import pytest
from driving_chains import FEASIBLE  # noqa: E402

from regen.driving.grounding.rules import ground_rule_based  # noqa: E402
from regen.driving.simulation.scenario import scenic_program  # noqa: E402

scenic = pytest.importorskip("scenic")

NARRATIVE = "a dog 🐕 runs"


def _is_lone_surrogate(ch: str) -> bool:
    return 0xD800 <= ord(ch) <= 0xDFFF


def test_emoji_in_narrative_reaches_scenic_intact() -> None:
    scenario = ground_rule_based(FEASIBLE["stop_abruptly"][2], seed=0)
    scenario = scenario.model_copy(update={"narrative": NARRATIVE})
    text = scenic_program(scenario)
    text.encode("utf-8")  # no lone surrogate in the program text itself
    # Scenic compiles the program, and the narrative it reads back is the one that was written:
    # a JSON '\ud83d\udc15' pair would be two lone surrogates in a Python string literal
    compiled = scenic.scenarioFromString(text, mode2D=True)
    got = compiled.params["regen_narrative"]
    assert not any(_is_lone_surrogate(ch) for ch in got), ascii(got)
    assert got == NARRATIVE
    got.encode("utf-8")


def test_lone_surrogate_and_controls_in_narrative_still_compile() -> None:
    scenario = ground_rule_based(FEASIBLE["stop_abruptly"][2], seed=0)
    scenario = scenario.model_copy(update={"narrative": 'half \ud83d of a dog, NUL \x00, quote """ end'})
    text = scenic_program(scenario)
    text.encode("utf-8")
    got = scenic.scenarioFromString(text, mode2D=True).params["regen_narrative"]
    assert not any(_is_lone_surrogate(ch) for ch in got), ascii(got)
    assert got.startswith("half ") and got.endswith('quote """ end')
