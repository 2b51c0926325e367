"""One exception root for everything the toolkit reports to a user.

Every error carries a message that says what happened and what to do about it. The CLI prints
these without a traceback; anything that is not a ``RegenError`` is a bug.
"""

from __future__ import annotations


class RegenError(Exception):
    """Root of all errors the toolkit raises on purpose."""

    #: Process exit code the CLI uses for this error family.
    exit_code = 2


class ConfigError(RegenError):
    """Bad user input or settings (unknown domain, empty behavior, bad option)."""


def install_hint(extra: str) -> str:
    """How to install an extra: no package is published yet, so from the project's checkout."""
    return f"pip install -e '.[{extra}]' in the regen checkout (bash setup.sh installs every extra but rl)"


class DependencyNotInstalled(RegenError):
    """An optional dependency is missing; the message carries the install command."""

    def __init__(self, package: str, extra: str, purpose: str = ""):
        self.package = package
        self.extra = extra
        what = f" (needed for {purpose})" if purpose else ""
        super().__init__(
            f"The package '{package}' is not installed{what}. "
            f"Install it with: {install_hint(extra)}"
        )


class AssetDatabaseError(RegenError):
    """A malformed asset database file; the message names the file and the key."""


class GraphError(RegenError):
    """A scenario graph that breaks its invariants."""


class GraphCycleError(GraphError):
    """Adding an edge (or loading a graph) would make the causal graph cyclic."""


# --- LLM layer -------------------------------------------------------------------------------


class LLMError(RegenError):
    """Base of the errors raised by the LLM layer."""


class UnknownProviderError(LLMError):
    """The provider string does not name a known provider."""


class MissingAPIKeyError(LLMError):
    """The provider needs a key that is not in the environment."""


class ProviderUnreachableError(LLMError):
    """The provider could not be reached or kept failing after retries."""


class ProviderResponseError(LLMError):
    """The provider answered with an error that retrying will not fix (4xx other than 429)."""


class MalformedAnswerError(LLMError):
    """The model's answer did not validate against the schema after the re-ask cap."""


class CacheMissError(LLMError):
    """Replay mode forbids model calls and the answer was not in the cache."""


class CacheCorruptedError(LLMError):
    """The cache file is not a readable cache."""


class ModelFileError(LLMError):
    """The local model file is missing, incomplete or fails its checksum."""


# --- grounding and simulation ----------------------------------------------------------------


class GroundingError(RegenError):
    """A cause chain could not be turned into a scenario (recorded as a verdict, not fatal)."""


class UngroundableError(GroundingError):
    """Grounding cannot honor what the causal graph decided for an entity (a behavior its asset
    does not support, a start location its behavior or the map cannot have); the message names
    the entity, the property and the value. Never swapped silently for something else."""


class SimulationError(RegenError):
    """The simulator failed on a scenario (recorded as a verdict, not fatal)."""


class RunError(RegenError):
    """A run folder is unusable (wrong behavior for the folder, unreadable state)."""


class StorageError(RunError):
    """The run folder cannot be written (a full disk, a read-only folder); the run stops and is
    resumed by the same command once there is room."""
