"""Property states in the storyboard: a traffic light's through the standard's signal action,
doors, sirens and hazard lights through custom commands.

=================  ==========================================================================
property           action
=================  ==========================================================================
light_state        ``TrafficSignalStateAction`` on the map's signal for the light
                   (:mod:`regen.driving.interop.signals`); a global action
door               ``UserDefinedAction/CustomCommandAction type="regen:door"``, content
                   ``ENTITY=open`` or ``ENTITY=closed``
siren              ``... type="regen:siren"``, ``ENTITY=on|off``
hazard_lights      ``... type="regen:hazard_lights"``, ``ENTITY=on|off``
=================  ==========================================================================

OpenSCENARIO 1.2 has ``AppearanceAction`` (a door's animation, a vehicle's special purpose and
warning lights), but its schema requires both a light state and an animation in every one (an
erratum fixed in 1.3), so a file that used it would fail the 1.2 schema and the ASAM checker;
custom commands are the standard's own way for actions it lacks (a player that does not know
them skips them). The first state goes into ``Init``, each change into an event on the actor's
trigger (:func:`regen.driving.interop.storyboard.state_group`). Brake lights follow the motion;
a driver's state, a sensor's signal and a camera's view stay ``Property`` entries.
Imports: scenariogeneration's xosc (passed in).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from typing import Any

APPEARANCE = ("door", "siren", "hazard_lights")
COMMAND = "regen:"  # custom command types: regen:door, regen:siren, regen:hazard_lights
_VALUES = {"door": ("open", "closed"), "siren": ("on", "off"), "hazard_lights": ("on", "off")}


def appearance_action(xosc: Any, key: str, value: str, entity: str) -> Any | None:
    """The action that puts ``entity``'s property ``key`` into ``value`` (None: none for it)."""
    if value not in _VALUES.get(key, ()):
        return None

    class _Command(xosc.CustomCommandAction):  # scenariogeneration writes it without its wrapper
        def get_element(self) -> ET.Element:
            outer = ET.Element("UserDefinedAction")
            outer.append(super().get_element())
            return outer

    return _Command(f"{COMMAND}{key}", f"{entity}={value}")


def read_command(type_: str, content: str) -> tuple[str, str, str] | None:
    """(entity, property, value) of a custom command this module writes (None: another's)."""
    key = type_[len(COMMAND):] if type_.startswith(COMMAND) else ""
    entity, sep, value = content.strip().partition("=")
    if key not in _VALUES or not sep or value not in _VALUES[key]:
        return None
    return entity.strip(), key, value


__all__ = ["APPEARANCE", "COMMAND", "appearance_action", "read_command"]
