"""A line harness (:mod:`line_harness`) whose policy runs in its own process like a user's: one
built-in policy, ``steady``, that prints what it is asked (into ``policy.log``); any other SPEC
is refused as a domain refuses an unknown name. A scenario whose id holds 'crash' runs the robot
into the box; a failure's picture is a tiny GIF. Test double of a domain's policy harness."""

from __future__ import annotations

import sys
from types import SimpleNamespace

from line_harness import LineHarness, line_trace

from regen.harness.contract import Episode
from regen.harness.loading import load_callable


def steady(obs):
    print(f"steady policy saw {obs['scenario']}", flush=True)
    print(f"steady policy warns about {obs['scenario']}", file=sys.stderr, flush=True)
    return 1.0


class PrintingHarness(LineHarness):
    builtin = {"steady": "moves at 1 m/s and says so"}

    def load_policy(self, spec):
        return load_callable(spec, {"steady": lambda: steady})

    def prepare(self, scenario):
        return SimpleNamespace(scenario=scenario, id=scenario.id)

    def run_policy(self, prepared, policy, *, step_timeout):
        policy({"scenario": prepared.id})  # one step, through the policy's process
        return Episode(trace=line_trace([0.0, 3.0, 6.0, 9.0] if "crash" in prepared.id else [0.0, 3.0, 6.0, 6.5]))

    def failure_picture(self, scenario, episode, prepared, case, policy, out):
        out.write_bytes(b"GIF89a\x01\x00\x01\x00\x00\x00\x00;")
        return out
