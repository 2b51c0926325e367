"""What the main job is asked to explain, from a command's options or a batch spec's entry: one
place, so ``regen generate`` and ``regen batch`` accept and refuse the same inputs.

Imports: the domains registry and core; no domain.
"""

from __future__ import annotations

from typing import Any

from regen import domains
from regen.core.behavior import Behavior, make_behavior
from regen.errors import ConfigError


def behavior_to_generate(behavior: str | None, domain: str, *, template: str | None = None,
                         reward: str | None = None, trajectory: str | None = None,
                         map_name: str | None = None) -> tuple[Behavior, list[str]]:
    """The behavior to explain: the text with the ego template (``--ego``) or reward
    (``--reward``) it names, or what a recorded ego trajectory shows; with the lines that say
    what was read from the trajectory (empty without one). ConfigError saying what to give."""
    extra: dict[str, Any] = {}
    if template:
        extra["ego_template"] = template
    if reward:
        extra["reward"] = reward
    lines: list[str] = []
    if trajectory is not None:
        if template:
            raise ConfigError("--ego and --ego-trajectory both say what the ego does; give one")
        recorder = domains.make(domain).recorder()
        if recorder is None:
            raise ConfigError(f"the {domain} domain takes no recorded trajectory; give the behavior as text")
        recorded = recorder.read(trajectory, text=behavior, options={} if map_name is None else {"map": map_name})
        behavior = recorded.text
        extra.update(recorded.params)
        lines = list(recorded.lines)
    elif map_name is not None:
        raise ConfigError("--map says which map an --ego-trajectory file's coordinates are in; give the file too")
    elif behavior is None:
        raise ConfigError("give the behavior as text (e.g. 'the ego-vehicle stops abruptly') or a recorded "
                          "trajectory with --ego-trajectory FILE")
    return make_behavior(behavior, domain, **extra), lines


def export_options(domain: str, no_ego_story: bool) -> dict[str, bool]:
    """The run's export options from the flags; ConfigError when the domain's export takes none such."""
    if not no_ego_story:
        return {}
    if "ego_story" not in domains.make(domain).export_options:
        raise ConfigError(f"--no-ego-story: the {domain} domain's export has no ego story; leave the flag out")
    return {"ego_story": False}


__all__ = ["behavior_to_generate", "export_options"]
