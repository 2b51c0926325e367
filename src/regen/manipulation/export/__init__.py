"""Exports of a manipulation run for other tools: its verified scenarios as robot-learning
episodes in the LeRobot v3 dataset layout (:func:`~regen.manipulation.export.lerobot.write_lerobot`),
read back by LeRobot's own loader in its own environment
(:mod:`~regen.manipulation.export.lerobot_check`).

Imports: ``render`` and every lower stage of this domain, the shared harness catalog and run
folder readers; pyarrow (the ``dataset`` extra), never ``lerobot`` itself (it runs in a subprocess).
"""

from regen.manipulation.export.lerobot import write_lerobot

__all__ = ["write_lerobot"]
