"""Run the real `regen` CLI in a subprocess with a scripted model plugged in as the provider
`--llm scripted`, for tests that send signals or kill the process (test double of a model only).

    python scripted_cli.py generate BEHAVIOR --domain driving --out RUN --llm scripted ...

Environment: REGEN_TEST_SLOW=<prompt kind> (propose, judge, entities, properties, other) makes
every answer of that kind take REGEN_TEST_SLOW_S seconds (default 30), so a signal lands there.
"""

from __future__ import annotations

import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from fake_expansion_model import ScriptedModel  # noqa: E402

from regen.llm import registry  # noqa: E402
from regen.llm.testing import FunctionProvider  # noqa: E402

STOP = "the ego-vehicle stops abruptly while driving forward"
CAUSES = ["a child runs across the road", "a parked car opens its door"]
MODEL = ScriptedModel(causes={STOP: CAUSES},
                      entities={CAUSES[0]: ["child"], CAUSES[1]: ["parked_car"]},
                      choose={"behavior": ["cross_the_road"], "door": ["opens"],
                              "start_location": ["roadside_ahead"]},
                      otherwise="not json")


def answer(messages):
    text = MODEL(messages)
    if MODEL.kinds[-1] == os.environ.get("REGEN_TEST_SLOW"):
        time.sleep(float(os.environ.get("REGEN_TEST_SLOW_S", "30")))
    return text


registry.register_provider("scripted", lambda name, **kw: FunctionProvider(answer))

if __name__ == "__main__":
    from regen.cli import main

    sys.argv = ["regen", *sys.argv[1:]]
    main()
