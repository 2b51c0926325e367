"""Near-duplicate causes merge; the shared module names no domain, the domain's own stop words
(``Wording.stop_words``) are ignored when the caller passes them."""

from __future__ import annotations

from pathlib import Path

from regen.expand import dedupe
from regen.expand.dedupe import merge, similar
from regen.expand.edges import domain_view


def test_the_driving_words_for_the_ego_are_stop_words_of_the_domain_only() -> None:
    stop = domain_view("driving").wording.stop_words
    assert {"ego", "vehicle"} <= set(stop)
    a, b = "a truck blocks the ego-vehicle's lane", "a truck blocks the lane"
    assert similar(a, b, stop=stop) and not similar(a, b)
    assert merge([a, b], stop=stop) == ([a], {b: a})
    assert merge([a, b]) == ([a, b], {})
    assert domain_view("manipulation").wording.stop_words == ()
    assert similar("the robot opens the door", "The robot opens the door!")


def test_the_shared_module_names_no_domain() -> None:
    text = Path(dedupe.__file__).read_text()
    assert not {"ego", "vehicle", "ego-vehicle"} & set(dedupe.STOP_WORDS)
    assert "ego" not in text and "vehicle" not in text
