"""FSM answers as the driving grounding schema wants them, written state by state in tests."""

from __future__ import annotations

from typing import Any


def state(stage: int, actor: str, name: str, *holds: str) -> dict[str, Any]:
    """One state of ``actor`` at ``stage`` (grouped per actor by :func:`fsm`)."""
    return {"stage": stage, "actor": actor, "name": name, "holds": list(holds)}


def fsm(*states: dict[str, Any]) -> dict[str, Any]:
    """The per-actor answer ``{"states": {actor: [state, ...]}}`` of ``states``, the other actors
    in order of appearance and the ego last, as the schema lists them."""
    per: dict[str, list[dict[str, Any]]] = {}
    for s in states:
        per.setdefault(s["actor"], []).append({k: v for k, v in s.items() if k != "actor"})
    order = [a for a in per if a != "ego"] + (["ego"] if "ego" in per else [])
    return {"states": {a: per[a] for a in order}}
