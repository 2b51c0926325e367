"""Generated furniture URDFs: well formed, naming the joint and handle the tasks use."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import pytest

from regen.manipulation.world.furniture import FURNITURE, furniture


@pytest.mark.parametrize("kind", sorted(FURNITURE))
def test_urdf_is_well_formed_and_names_its_joint(kind):
    spec = furniture(kind)
    root = ET.fromstring(spec.urdf)
    joints = {j.get("name"): j for j in root.iter("joint")}
    links = {link.get("name") for link in root.iter("link")}
    if spec.joint:
        assert spec.joint in joints and joints[spec.joint].get("type") in ("revolute", "prismatic")
    if spec.handle_link:
        assert spec.handle_link in links
    # materials are unique per visual (PyBullet shares colours between equal names)
    names = [m.get("name") for m in root.iter("material")]
    assert len(names) == len(set(names))
