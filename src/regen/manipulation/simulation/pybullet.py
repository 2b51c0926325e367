"""Lazy import of PyBullet: a missing wheel is reported with the extra that installs it."""

from __future__ import annotations

from types import ModuleType

from regen.errors import DependencyNotInstalled


def pybullet() -> ModuleType:
    """The ``pybullet`` module, or :class:`DependencyNotInstalled` naming the extra."""
    try:
        import pybullet
    except ImportError:
        raise DependencyNotInstalled("pybullet", "manipulation", "manipulation simulation") from None
    return pybullet


def pybullet_data_path() -> str:
    """Folder of the URDFs and meshes that ship with the pybullet wheel (Panda, mug, duck...)."""
    try:
        import pybullet_data
    except ImportError:
        raise DependencyNotInstalled("pybullet", "manipulation", "the Franka Panda model") from None
    return pybullet_data.getDataPath()


__all__ = ["pybullet", "pybullet_data_path"]
