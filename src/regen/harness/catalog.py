"""The verified scenarios of one or more run folders, as training and test episodes pick them
(the Gymnasium envs of every domain)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from regen.errors import ConfigError


@dataclass
class Entry:
    """One verified scenario: its name (``run/folder`` when several runs are given)."""

    name: str
    folder: Any  # regen.runfolder.ScenarioFolder
    scenario: Any  # regen.core.scenario.Scenario
    prepared: Any = None  # what the domain's harness prepared for it, kept across episodes
    template_trace: Any = None  # the scripted robot's trace, read on first use


def verified(runs: str | Path | list, domain: str) -> tuple[list[Entry], list[str]]:
    """(the verified ``domain`` scenarios of ``runs``, the names of those that did not verify);
    ConfigError for a folder that is not a run."""
    from regen.runfolder import RunFolder

    runs = [runs] if isinstance(runs, (str, Path)) else list(runs)
    out, skipped = [], []
    for run in runs:
        rf = RunFolder(run)
        if not (rf.path / RunFolder.SCENARIOS).is_dir():
            raise ConfigError(f"{rf.path} is not a run folder with scenarios (regen generate makes one)")
        for name, folder, scenario, verdict in rf.scenarios_of(domain):
            if verdict is None or not verdict.feasible:
                skipped.append(f"{rf.path.name}/{name}")
                continue
            out.append(Entry(name if len(runs) == 1 else f"{rf.path.name}/{name}", folder, scenario))
    return out, skipped


class Picker:
    """Which entry the next episode runs: ``options={"scenario": NAME}`` picks by name, else
    'random' (the env's seeded generator) or 'cycle' (round robin; a seeded reset starts at
    ``seed % n``)."""

    def __init__(self, entries: list[Entry], order: str) -> None:
        if order not in ("random", "cycle"):
            raise ConfigError(f"order must be 'random' or 'cycle' (got {order!r})")
        self.entries, self.order, self._cursor = entries, order, 0

    def pick(self, options: dict | None, rng: Any, seed: int | None) -> Entry:
        if options and options.get("scenario") is not None:
            want = str(options["scenario"])
            for e in self.entries:
                if e.name == want:
                    return e
            raise ConfigError(f"no scenario {want!r}; choose one of: {', '.join(e.name for e in self.entries)}")
        n = len(self.entries)
        if self.order == "random":
            return self.entries[int(rng.integers(n))]
        if seed is not None:
            self._cursor = int(seed) % n
        entry = self.entries[self._cursor % n]
        self._cursor = (self._cursor + 1) % n
        return entry


__all__ = ["Entry", "Picker", "verified"]
