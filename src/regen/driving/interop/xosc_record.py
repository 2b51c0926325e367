"""What the OpenSCENARIO reader (:mod:`.xosc_read`) reads of a file, and the naming of all it
does not read.

Each element of the file records, in its file's :class:`Record`, the elements the reader finds
through it and the attributes it gets (:class:`RecordingElement`); what is left is named by
:func:`unread`, unless it has no effect on a kinematic replay on a generated map
(:data:`WITHOUT_EFFECT`, :data:`SAME`). Numbers and choices are read by :func:`number` and
:func:`choice`, which name a value they cannot read and go on, so that one message names every
problem of the file. Imports: the standard library and the promises only.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

from regen.promises.files import shown

MAX_ABS = 1e9  # [m, s, m/s, rad] a number beyond this in a scenario is a mistake, not a place

#: elements with no effect on a kinematic replay on a generated map: not read, not named
#: ('Parent/Tag' where the tag means something elsewhere)
WITHOUT_EFFECT = frozenset({
    "CatalogLocations", "License", "FileHeader/Properties", "SceneGraphFile", "ObjectController", "Performance",
    "Axles", "Center", "TrajectoryFollowingMode"})
#: elements that only hold others: when the reader reads none of what they hold, what they hold
#: is named one by one (each parameter declaration, each property), not the holder
HOLDERS = frozenset({"ParameterDeclarations", "RoadNetwork", "Entities", "Init", "Actions", "Properties",
                     "StartTrigger", "StopTrigger", "Maneuver"})
ANY = None
#: tag -> attribute -> the values that mean what the replay does anyway (ANY: every value)
SAME: dict[str, dict[str, frozenset[str] | None]] = {
    "*": {"name": ANY},  # names label things; entities and events are read by theirs
    "FileHeader": {"revMinor": ANY, "date": ANY, "author": ANY},
    "Vehicle": {"mass": ANY, "model3d": ANY},
    "Pedestrian": {"mass": ANY, "model": ANY, "model3d": ANY},
    "MiscObject": {"mass": ANY, "model3d": ANY},
    "WorldPosition": {"z": ANY, "p": ANY, "r": ANY},  # the replay is in the plane
    "ManeuverGroup": {"maximumExecutionCount": frozenset({"1"})},
    # the replay lets an entity's later event override its earlier motion, whatever the priority
    "Event": {"priority": ANY, "maximumExecutionCount": frozenset({"1"})},
    "Condition": {"conditionEdge": frozenset({"none", "rising"})},  # an event starts once
    "Actors": {"selectTriggeringEntities": frozenset({"false"})},
    "TriggeringEntities": {"triggeringEntitiesRule": ANY},  # one entity: any is all
    "DistanceCondition": {"freespace": frozenset({"false"}), "coordinateSystem": ANY, "alongRoute": frozenset({"false"}),
                          "relativeDistanceType": frozenset({"euclidianDistance", "cartesianDistance"})},
    "TimeToCollisionCondition": {"freespace": frozenset({"false"}), "coordinateSystem": ANY,
                                 "alongRoute": frozenset({"false"}),
                                 "relativeDistanceType": frozenset({"euclidianDistance", "cartesianDistance"})},
    "RelativeDistanceCondition": {"freespace": frozenset({"false"}), "coordinateSystem": frozenset({"entity"})},
    "Trajectory": {"closed": frozenset({"false"})},
    "SpeedActionDynamics": {"followingMode": ANY},
    "LaneChangeActionDynamics": {"followingMode": ANY},
}


class Record:
    """What the reader read of one file (elements and attributes, by the element's id) and what
    it names as not read."""

    def __init__(self) -> None:
        self.read: set[int] = set()
        self.attrs: set[tuple[int, str]] = set()
        self.named: set[int] = set()  # elements named by the reader itself (their subtree is not named again)
        self.bad: list[str] = []


class RecordingElement(ET.Element):
    """An element that records, in its file's :class:`Record` (``record``, set on a subclass
    made for each file), every element the reader finds through it and every attribute it gets:
    what is left is what the reader does not read. Paths are plain tag paths ('A/B/C')."""

    record: Record

    def get(self, key, default=None):  # type: ignore[override]
        self.record.attrs.add((id(self), key))
        return super().get(key, default)

    def _chains(self, path: str):
        """Every chain of elements, child by child, that ``path`` leads to, in document order."""
        tags = path.split("/")

        def walk(el: ET.Element, i: int, chain: list[ET.Element]):
            if i == len(tags):
                yield chain
                return
            for c in el:
                if c.tag == tags[i]:
                    yield from walk(c, i + 1, [*chain, c])

        yield from walk(self, 0, [])

    def find(self, path, namespaces=None):  # type: ignore[override]
        for chain in self._chains(path):
            self.record.read.update(id(e) for e in chain)
            return chain[-1]
        return None

    def findall(self, path, namespaces=None):  # type: ignore[override]
        out = []
        for chain in self._chains(path):
            self.record.read.update(id(e) for e in chain)
            out.append(chain[-1])
        return out


def bad(el: ET.Element, what: str) -> None:
    """Name ``what`` as not read (``el``: any element of the file)."""
    el.record.bad.append(what)  # type: ignore[attr-defined]


def named(el: ET.Element, where: str) -> None:
    """Name the element ``el`` (and so all it holds) as not read."""
    el.record.named.add(id(el))  # type: ignore[attr-defined]
    bad(el, f"{tag(el)} in {where}")


def mark(el: ET.Element) -> None:
    el.record.read.add(id(el))  # type: ignore[attr-defined]


def tag(el: ET.Element) -> str:
    """The element for a message: ``<Event 'brake'>``."""
    name = ET.Element.get(el, "name")  # not a read: the name says which one it is
    short = el.tag if len(el.tag) <= 60 else el.tag[:60] + "..."
    return f"<{short} {shown(name, 40)}>" if name else f"<{short}>"


def number(el: ET.Element, attr: str, where: str, default: float | None = None) -> float:
    """The number in ``attr``; a missing (without ``default``), non-numeric, non-finite or huge
    value is named and reads as NaN (so no check on it fires again)."""
    raw = el.get(attr)
    if raw is None:
        if default is not None:
            return default
        bad(el, f"{tag(el)} in {where} without {attr} (a number)")
        return math.nan
    if raw.startswith("$"):
        return math.nan  # a parameter reference: named with the declared value (_parameters)
    try:
        value = float(raw)
    except ValueError:
        bad(el, f"{attr}={shown(raw)} of {tag(el)} in {where} (not a number)")
        return math.nan
    if not math.isfinite(value) or abs(value) > MAX_ABS:
        bad(el, f"{attr}={shown(raw)} of {tag(el)} in {where} (not a finite number within ±{MAX_ABS:g})")
        return math.nan
    return value


def choice(el: ET.Element, attr: str, where: str, choices: tuple[str, ...], default: str) -> str:
    """The value of ``attr``, one of ``choices`` (``default`` when absent); another is named."""
    raw = el.get(attr)
    if raw is None:
        return default
    if raw not in choices and not raw.startswith("$"):
        bad(el, f"{attr}={shown(raw)} of {tag(el)} in {where} (the values read: {', '.join(choices)})")
    return raw if raw in choices else default


def _parameters(root: ET.Element) -> dict[str, str]:
    """Every declared parameter's value by its name (read without recording: declarations are
    not read, only quoted where a reference to one is named)."""
    return {ET.Element.get(d, "name", ""): ET.Element.get(d, "value", "")
            for d in ET.Element.iter(root, "ParameterDeclaration")}


def _where(el: ET.Element, where: str) -> str:
    """Where the children of ``el`` are, for a message: from its nearest named element down."""
    name = ET.Element.get(el, "name") or ET.Element.get(el, "entityRef")
    if name:
        return f"{el.tag} {shown(name, 40)}"
    return f"{where}/{el.tag}" if where else el.tag


def unread(root: ET.Element, rec: Record) -> list[str]:
    """Every element and attribute of the file the reader did not read and that is not without
    effect (:data:`WITHOUT_EFFECT`, :data:`SAME`), and every parameter reference, in document
    order; an element not read is named once, not with all it holds."""
    params = _parameters(root)
    out: list[str] = []
    stack: list[tuple[ET.Element, str, str]] = [(root, "", "")]
    while stack:
        el, parent, where = stack.pop()
        if id(el) in rec.named or el.tag in WITHOUT_EFFECT or f"{parent}/{el.tag}" in WITHOUT_EFFECT:
            continue
        read = id(el) in rec.read or el is root
        if not read and el.tag not in HOLDERS:
            why = " (parameters are not substituted: write the value where it is used)" \
                if el.tag == "ParameterDeclaration" else ""
            out.append(f"{tag(el)} in {where or 'the file'}{why}")
            continue
        for attr, value in el.attrib.items():
            if attr.startswith("{"):  # a namespaced attribute: the schema's location, not the scenario
                continue
            if value.startswith("$"):
                declared = params.get(value[1:].strip("{}"))
                value_words = f": write its value, {shown(declared)}" if declared else ", declared nowhere"
                out.append(f"{attr}={shown(value)} of {tag(el)} in {where or 'the file'} (a parameter reference"
                           f"{value_words}; regen import does not substitute parameters)")
                continue
            same = SAME.get(el.tag, {}).get(attr, SAME["*"].get(attr, frozenset()))
            if (id(el), attr) in rec.attrs or same is ANY or value in same:
                continue
            out.append(f"{attr}={shown(value)} of {tag(el)} in {where or 'the file'}")
        inside = _where(el, where) if el is not root else ""
        stack.extend((c, el.tag, inside) for c in reversed(list(el)))
    return out


def element_class() -> type[RecordingElement]:
    """The element factory for one file: a subclass with a record of its own."""
    return type("_FileElement", (RecordingElement,), {"record": Record()})


__all__ = ["HOLDERS", "MAX_ABS", "SAME", "WITHOUT_EFFECT", "Record", "RecordingElement", "bad", "choice",
           "element_class", "mark", "named", "number", "tag", "unread"]
