"""Traffic signals for the OpenSCENARIO export: the scenario's traffic lights as OpenDRIVE
``<signal>`` elements of the exported map, so the storyboard switches them with the standard's
``TrafficSignalStateAction`` (a player, the ASAM checker and CARLA find the signal by its id).

The generated maps carry no signals (a light is placed per scenario), so the exported copy of the
map gets one ``<signal>`` per light on the road whose straight reference line passes nearest
to it: ``s`` along that line, ``t`` to its left [m], facing the traffic that drives along the
road (``orientation`` ``+``) or against it (``-``) as the light faces. The roads, lanes and
junctions are unchanged: :func:`without_signals` gives back the generated map's text, which is
how ``regen import`` recognises the map.

Imports: the standard library only.
"""

from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass

FIRST_ID = 9001  # signal ids: numeric (CARLA's OpenDRIVE parser reads numbers), above the map's own ids
_SIGNALS = re.compile(r"\s*<signals>.*?</signals>", re.DOTALL)


@dataclass(frozen=True)
class Light:
    name: str  # the OpenSCENARIO entity's name (the signal's name too)
    x: float  # [m]
    y: float  # [m]
    heading: float  # [rad from +x], the way the light faces


def signal_id(index: int) -> str:
    return str(FIRST_ID + index)


def _nearest_line(root: ET.Element, x: float, y: float) -> tuple[ET.Element, float, float, float] | None:
    """(road, s, t, road heading there) of the straight reference line nearest to (x, y)."""
    best = None
    for road in root.findall("road"):
        for g in road.findall("planView/geometry"):
            if g.find("line") is None:
                continue
            gx, gy, hdg, s0, length = (float(g.get(k, "0")) for k in ("x", "y", "hdg", "s", "length"))
            ux, uy = math.cos(hdg), math.sin(hdg)
            along = (x - gx) * ux + (y - gy) * uy
            if not 0.0 <= along <= length:
                continue
            t = -(x - gx) * uy + (y - gy) * ux
            if best is None or abs(t) < abs(best[2]):
                best = (road, s0 + along, t, hdg)
    return best


def with_signals(xodr_text: str, lights: list[Light]) -> tuple[str, dict[str, str]]:
    """The map with a ``<signal>`` per light; (its text, light name -> signal id). A light that
    lies beside no straight road gets no signal (left out of the mapping)."""
    root = ET.fromstring(xodr_text)
    ids: dict[str, str] = {}
    for i, light in enumerate(lights):
        hit = _nearest_line(root, light.x, light.y)
        if hit is None:
            continue
        road, s, t, hdg = hit
        facing = math.cos(light.heading - hdg)  # the light faces traffic coming against its heading
        signals = road.find("signals")
        if signals is None:
            signals = ET.Element("signals")
            after = road.find("objects") if road.find("objects") is not None else road.find("lanes")
            kids = list(road)
            road.insert(kids.index(after) + 1 if after is not None else len(kids), signals)
        ET.SubElement(signals, "signal", {
            "s": f"{s:.4f}", "t": f"{t:.4f}", "id": signal_id(i), "name": light.name, "dynamic": "yes",
            "orientation": "-" if facing > 0 else "+", "zOffset": "0.0", "country": "OpenDRIVE",
            "type": "1000001", "subtype": "-1", "value": "-1", "height": "3.0", "width": "0.5",
            "hOffset": "0.0", "pitch": "0.0", "roll": "0.0"})
        ids[light.name] = signal_id(i)
    ET.indent(root, space="    ")
    return '<?xml version="1.0" encoding="utf-8"?>\n' + ET.tostring(root, encoding="unicode") + "\n", ids


def _root(xodr: str | ET.Element) -> ET.Element:
    return ET.fromstring(xodr) if isinstance(xodr, str) else xodr


def _number(el: ET.Element, key: str) -> float:
    """The number in ``key`` of ``el`` (0 when absent); ValueError naming the element, the
    attribute and the value when it is not a finite number."""
    raw = el.get(key, "0")
    try:
        value = float(raw)
    except ValueError:
        value = math.nan
    if not math.isfinite(value):
        shown = repr(raw if len(raw) <= 40 else raw[:40] + "...")
        raise ValueError(f"<{el.tag} id={el.get('id', '')!r}> has {key}={shown}, not a finite number")
    return value


def without_signals(xodr: str | ET.Element) -> str:
    """The map's text without its ``<signals>`` blocks, normalised (for comparing maps); a parsed
    map (``xodr``: its root element) loses them in place."""
    root = _root(xodr)
    for road in root.findall("road"):
        for sig in road.findall("signals"):
            road.remove(sig)
    ET.indent(root, space="    ")
    return ET.tostring(root, encoding="unicode")


def signals_of(xodr: str | ET.Element) -> dict[str, tuple[str, float, float]]:
    """Signal id -> (name, x, y) [m] of every signal on a straight reference line of the map
    (its text or its root element); ValueError naming a signal or geometry whose ``s``, ``t``,
    ``x``, ``y``, ``hdg`` or ``length`` is not a number."""
    root = _root(xodr)
    out: dict[str, tuple[str, float, float]] = {}
    for road in root.findall("road"):
        lines = [g for g in road.findall("planView/geometry") if g.find("line") is not None]
        for sig in road.findall("signals/signal"):
            s, t = _number(sig, "s"), _number(sig, "t")
            for g in lines:
                gx, gy, hdg, s0, length = (_number(g, k) for k in ("x", "y", "hdg", "s", "length"))
                if s0 <= s <= s0 + length:
                    a = s - s0
                    out[sig.get("id", "")] = (sig.get("name", ""), gx + a * math.cos(hdg) - t * math.sin(hdg),
                                              gy + a * math.sin(hdg) + t * math.cos(hdg))
                    break
    return out


__all__ = ["FIRST_ID", "Light", "signal_id", "signals_of", "with_signals", "without_signals"]
