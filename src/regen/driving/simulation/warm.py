"""The once-per-process work of a driving worker's first scenario, done ahead of it.

A fresh worker process (a Ray worker, a pool worker forked before the driver loaded Scenic) spent
about 1.7 s more on its first scenario than on the next ones (issue 39, measured cold): importing
Scenic (0.7 s), translating the world model's modules and parsing the program's fixed helpers
into the process's caches (:mod:`regen.driving.simulation.compile_cache`,
:mod:`~regen.driving.simulation.parse_cache`: 0.7 s) and importing the exports' package (0.3 s).
:func:`warm` does that work by compiling an ego-only program, so a batch can have its workers do
it while the driver still expands its first behaviors. The translations and that program's
parsed statements are kept on disk (:mod:`regen.driving.simulation.scenic_disk`), so a later
process reads them instead (a cold warm-up 2.4-3.2 s, from disk about 1.4 s, mostly Scenic's
imports). Nothing is simulated and nothing written except the generated map's file, which every
scenario on that map needs anyway.
"""

from __future__ import annotations

WARM_MAP = "straight"  # the first map the scenarios of the ego templates use


def warm(map_name: str = WARM_MAP) -> None:
    """Compile an ego-only program on ``map_name`` and import what a scenario's exports import.
    (:meth:`regen.driving.backend.DrivingBackend.warm` adds the causal check's modules, which
    this layer does not import, and times the whole.)"""
    from regen.driving.simulation import parse_cache, scenic_disk
    from regen.driving.simulation.program import write_program
    from regen.driving.simulation.run import compile_program
    from regen.driving.world.maps import ensure_map
    from regen.driving.world.plan import ActorPlan

    ego = ActorPlan(name="ego", asset="car", kind="ego", cls="Car", x=0.0, y=0.0, heading=0.0,
                    length=4.5, width=2.0, height=1.5, route=[(0.0, 0.0), (10.0, 0.0)],
                    scenic_behavior="FollowRoute")
    program = write_program([ego], map_path=str(ensure_map(map_name)), dt=0.1, max_steps=1)
    parsed = parse_cache.stats["misses"]
    with parse_cache.recording() as used:
        compile_program(program)
    if parse_cache.stats["misses"] > parsed:  # not all read from disk: kept for the next process
        scenic_disk.write_parses(used)
    try:
        from scenariogeneration import xosc  # noqa: F401 (what the OpenSCENARIO export imports)
    except ModuleNotFoundError:  # the export itself says what to install, when it runs
        pass


__all__ = ["WARM_MAP", "warm"]
