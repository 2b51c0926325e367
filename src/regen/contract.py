"""The contract every simulation domain implements (its registry is :mod:`regen.domains`).

A domain package owns everything that is particular to its simulator: its name, its asset
database file, the wording the shared prompts use for it, its predicates, the files its
``render``/``export`` write (returned as role -> path, and recorded in the run folder) and the
captions the report shows for them. The shared packages (core, llm, expand, verify, assets,
report, evaluation) name no domain; they ask the backend. A new domain is a package with a
:class:`DomainBackend` subclass and one :func:`regen.domains.register` call; ``tests/test_domain_conformance.py``
runs every registered domain through the whole pipeline the way Gymnasium's ``check_env`` does.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar

from regen.core.behavior import BehaviorParams

if TYPE_CHECKING:
    from regen.assets.database import AssetDatabase
    from regen.core.behavior import Behavior
    from regen.core.graph import CausePath
    from regen.core.scenario import AbstractState, Scenario
    from regen.core.trace import Trace
    from regen.core.verdict import Verdict
    from regen.harness.contract import PolicyHarness
    from regen.llm.client import LLM
    from regen.verify.causal import ReferenceWorld

#: Well-known roles of the files ``render`` returns; the report shows them as pictures.
ANIMATION = "animation"
KEYFRAMES = "keyframes"


#: The default of :attr:`Wording.mechanics`: causes in which the robot is ordered or programmed
#: to act ("the robot is programmed to open doors", "a human asks the robot to ...").
ROBOT_ORDERS: tuple[str, ...] = (
    r"(?:^|\bthe\s+|\bthis\s+)robot\s+(?:is|was|gets|got|has\s+been|had\s+been)\s+(?:\w+ly\s+|just\s+)?"
    r"(?:programmed|commanded|instructed|ordered|told|asked|scheduled|designed|configured|tasked)\b",
    r"\b(?:asks?|asked|tells?|told|commands?|commanded|instructs?|instructed|orders?|ordered|programs?|"
    r"programmed)\s+(?:the\s+)?robot\b",
)


@dataclass(frozen=True)
class Wording:
    """The domain's words in the shared expansion prompts (``regen/expand/prompts``) and in the
    rules applied to the model's answers."""

    expert: str  # system prompt: "You are an expert in <expert>."
    situation: str  # "plausibly and directly cause the effect in a realistic <situation> situation"
    cause_rule: str  # event proposal: what a cause must be (and must not be)
    value_hint: str  # property proposal: how free values (locations) are phrased, with an example
    #: edge judge: worked examples shown before each question, as (effect, candidate cause,
    #: "yes" or "no", reason); a few short ones of the domain, none from the labeled edge set
    judge_examples: tuple[tuple[str, str, str, str], ...] = ()
    #: Regular expressions over the lower-cased cause text that mark a cause as a restatement of
    #: the robot's own command, programming, sensors or mechanics rather than a context of the
    #: world; expansion rejects such causes after the judge (``by="rule"``), unless the user
    #: insisted on them. Searched with ``re.search``; the first match is quoted in the reason.
    mechanics: tuple[str, ...] = ROBOT_ORDERS
    #: Causes that make the robot do the opposite of an effect, as (effect pattern, cause
    #: pattern, what the cause makes the robot do instead): a cause matching the second, of an
    #: effect of the robot matching the first, is rejected after the judge ('a pedestrian steps
    #: into the path' never makes a waiting ego-vehicle drive off). Searched with ``re.search``
    #: in the lower-cased texts, in order (the first effect pattern that matches decides); only
    #: effects that name the robot are tested.
    opposites: tuple[tuple[str, str, str], ...] = ()
    #: entity judge: worked examples shown before each question whether an entity the model
    #: added takes part in an event, as (event, entity, "yes" or "no"); a few short ones of the
    #: domain, none from a labeled set
    entity_examples: tuple[tuple[str, str, str], ...] = ()
    #: Database categories whose members play one part in a cause: an asset of one of them that
    #: the model adds beside one the cause's words name is refused (a traffic queue added to 'the
    #: front car', bound to a sedan). Empty: categories too coarse to say (every asset one kind).
    one_part_per_category: tuple[str, ...] = ()
    #: Phrases a cause uses for the robot itself ('the vehicle' in "a cyclist crosses while the
    #: vehicle is moving"): they name no asset of the database. A phrase starting with 'the'
    #: still names another one when a place follows ('the vehicle ahead').
    robot_names: tuple[str, ...] = ()
    #: Words of the domain that carry no meaning when telling near-duplicate texts apart (the
    #: words for the robot, say), on top of the shared English ones (``regen.expand.dedupe``).
    #: Lower case, one word each.
    stop_words: tuple[str, ...] = ()
    #: what-if: worked examples shown before the user's question, as (scenario's cause,
    #: question, the edits as JSON); in the domain's own entities and properties
    whatif_examples: tuple[tuple[str, str, str], ...] = ()
    #: what-if: a short cause text of the domain that names the thing it adds and what it does,
    #: shown as the example of an added cause
    add_example: str = ""
    #: augment: the same, for a cause that would cause or strengthen a behavior
    augment_example: str = ""


@dataclass(frozen=True)
class ReportHints:
    """What the report calls this domain's pictures and actors."""

    animation: str = "animation of the run"
    keyframes: str = "key frames (click for full size)"
    robot: str = "robot"  # what the report calls the robot whose behavior is explained
    #: [px] the width of one key frame in the strip: a scenario card shows the strip's last frame
    #: at its own aspect (0: a 4:3 crop of the strip's right end)
    keyframe_width: int = 0
    #: the behavior tests record the robot's time to collision and gap (``regen test``); a
    #: domain that measures neither gets no such columns
    proximity: bool = False
    #: what the domain's numbers mean: a solved parameter or a world setting by name ->
    #: (meaning, unit), e.g. ``{"v": ("speed", "m/s")}``; unit '' for none. The report shows the
    #: meaning beside the name and the unit beside the value; names left out show as they are.
    quantities: Mapping[str, tuple[str, str]] = field(default_factory=dict)


@dataclass
class SimulationOutput:
    trace: Trace
    timings: dict[str, float] = field(default_factory=dict)  # stage -> wall seconds
    files: dict[str, Path] = field(default_factory=dict)  # role -> path of a file the run wrote


#: property -> the values it may take (with one value of :attr:`PropertyChoices.key`)
Allowed = dict[str, list[str]]


@dataclass(frozen=True)
class PropertyChoices:
    """Properties of an entity whose values the simulator restricts
    (:meth:`DomainBackend.property_choices`). Expansion asks the model for one consistent
    choice, so the graph never holds a combination grounding cannot honor.

    Once the entity's ``key`` property (a driving actor's ``behavior``) takes a value, the other
    properties may only take the values ``allowed`` lists for it, and a property left out does not
    apply at all (a stationary actor has no speed). A value of ``key`` may allow a list of such
    dicts instead: alternatives where the other properties depend on each other too (a car ahead
    in the ego's lane, before the ego stops, is no slow one; in the next lane it may be). With
    ``key`` None the one entry, under None, holds whatever the entity's values
    (:meth:`fixed`): the start state of the object a manipulation task acts on, which the task
    fixes.
    """

    key: str | None
    allowed: dict[str | None, Allowed | list[Allowed]]

    def __post_init__(self) -> None:
        if self.key is None and list(self.allowed) != [None]:
            raise ValueError("PropertyChoices without a key property holds one entry, under None "
                             "(PropertyChoices.fixed)")

    @classmethod
    def fixed(cls, allowed: Allowed) -> PropertyChoices:
        """Restrictions that hold whatever the entity's other values."""
        return cls(None, {None: allowed})

    def alternatives(self, value: str | None) -> list[Allowed | None]:
        """The alternatives of one key value's restriction: one unless the domain gave several;
        ``[None]`` when it restricts nothing for that value."""
        allowed = self.allowed.get(value)
        return list(allowed) if isinstance(allowed, list) else [allowed]

    def dependent(self) -> set[str]:
        """The properties some value of the key restricts (in any alternative)."""
        return {p for value in self.allowed for alt in self.alternatives(value) for p in (alt or {})}


class Importer(ABC):
    """How ``regen import`` reads files another tool wrote into a domain's scenarios
    (:meth:`DomainBackend.importer`)."""

    #: the file suffixes it reads, lower case with the dot (``(".xosc",)``)
    suffixes: ClassVar[tuple[str, ...]] = ()

    @abstractmethod
    def read(self, path: Path) -> Scenario:
        """A scenario from the file (one of :attr:`suffixes`), ready to simulate: its FSM derived
        from the file; :class:`~regen.errors.ConfigError` naming what cannot be read."""

    def notes(self, scenario: Scenario) -> list[str]:
        """What the reading of an imported scenario left out or changed, in words (``regen import``
        prints them). Default: nothing."""
        return []


@dataclass(frozen=True)
class RecordedBehavior:
    """A behavior read from a recorded trajectory (:meth:`Recorder.read`)."""

    text: str  # the text given, or the one detected
    params: dict[str, Any]  # the behavior's parameters (``Behavior.params``)
    lines: tuple[str, ...] = ()  # what was detected, in words (``regen generate`` prints them)


class Recorder(ABC):
    """How ``regen generate --ego-trajectory FILE`` reads a recorded trajectory of the robot into
    the behavior to explain (:meth:`DomainBackend.recorder`)."""

    #: The options :meth:`read` takes: name -> what it says (``--map NAME`` gives ``map``).
    options: ClassVar[Mapping[str, str]] = {}

    def check_options(self, options: Mapping[str, str]) -> None:
        """:class:`~regen.errors.ConfigError` naming an option not in :attr:`options` and the
        ones taken (what :meth:`read` checks first)."""
        from regen.errors import ConfigError

        for key in options:
            if key not in self.options:
                takes = "; ".join(f"{k}: {what}" for k, what in self.options.items()) or "none"
                raise ConfigError(f"a recorded trajectory of this domain takes no option {key!r} "
                                  f"(the options it takes: {takes})")

    @abstractmethod
    def read(self, path: str | Path, *, text: str | None = None,
             options: Mapping[str, str] | None = None) -> RecordedBehavior:
        """The behavior the recording shows: ``text`` when given, else the detected one, with its
        parameters and what was detected in words. ``options``: :attr:`options` (refused with
        :meth:`check_options` when unknown); :class:`~regen.errors.ConfigError` naming what is
        wrong with the file."""


class DatasetViews(ABC):
    """What ``regen dataset`` needs of a domain (:meth:`DomainBackend.dataset_views`): the robot's
    reaction states, the pictures of a frame and a new simulation of a test variant."""

    @abstractmethod
    def reaction(self, scenario: Scenario) -> tuple[Callable[[AbstractState], bool],
                                                     tuple[AbstractState, list[AbstractState]]] | None:
        """For a scenario whose robot follows a known template: whether a state of the robot is a
        reaction, and the template's (first state, reaction states). None: no template known (the
        dataset reads the scenario's own states)."""

    @abstractmethod
    def camera_note(self) -> str:
        """Why there are no camera pictures on this machine; '' when there are."""

    @abstractmethod
    def pictures(self, scenario: Scenario, trace: Trace, verdict: Verdict, steps: list[int], *,
                 map_path: Path | None, camera: tuple[int, int] | None) -> dict[str, Any]:
        """PIL images per frame: ``bev_<k>`` (the bird's-eye view, nothing that names the answer)
        and, with ``camera`` (its size [px]), ``camera_<k>`` (the robot's forward view), k indexing
        ``steps``."""

    @abstractmethod
    def resimulate(self, scenario: Scenario) -> tuple[Trace | None, Verdict | None, Scenario, str]:
        """A test variant simulated again with the template robot: (trace, verdict, the scenario
        as judged, '' or the error)."""


@dataclass(frozen=True)
class TypologyCause:
    """A cause text that presents a typology class when the robot shows one of ``fits`` (the
    domain's own names of robot behaviors, :meth:`Typology.behavior_key`)."""

    text: str
    fits: tuple[str, ...] = ()


@dataclass(frozen=True)
class TypologyClass:
    """One class of a scenario typology (one of NHTSA's 37 pre-crash scenarios, say)."""

    id: str  # stable, what :meth:`Typology.classify` returns ('lead_vehicle_stopped')
    number: int  # the typology's own number (27)
    name: str  # the official name ('Lead vehicle stopped')
    description: str  # one line: the configuration a scenario must show
    #: whether the domain's generator can make a scenario of this class at all (False: the
    #: simulator lacks what it needs; :attr:`note` says what)
    simulable: bool = True
    note: str = ""  # why it cannot occur, or what limits it
    causes: tuple[TypologyCause, ...] = ()  # cause texts that present it (``regen batch --fill-coverage``)

    @property
    def label(self) -> str:
        """Number and name, as tables show it ('27 Lead vehicle stopped')."""
        return f"{self.number} {self.name}"


class Typology(ABC):
    """A standard list of situations a safety team names its tests by (the NHTSA pre-crash
    typology for driving) and the rules that say which of them a simulated scenario shows
    (:meth:`DomainBackend.typology`; ``regen eval --coverage``, ``regen batch --fill-coverage``).

    A scenario may show several classes, or none. Rules read the trace (what happened), never the
    model's text."""

    def __init__(self, name: str, classes: Sequence[TypologyClass], source: str = ""):
        ids = [c.id for c in classes]
        if len(set(ids)) != len(ids):
            raise ValueError(f"typology {name!r}: class ids repeat")
        self.name, self.source = name, source
        self.classes: tuple[TypologyClass, ...] = tuple(sorted(classes, key=lambda c: c.number))

    def get(self, class_id: str) -> TypologyClass:
        """The class of ``class_id``; KeyError naming the known ids."""
        for c in self.classes:
            if c.id == class_id:
                return c
        raise KeyError(f"no class {class_id!r} in {self.name} (known: {', '.join(c.id for c in self.classes)})")

    @abstractmethod
    def explain(self, scenario: Scenario, trace: Trace) -> dict[str, list[str]]:
        """The classes the scenario shows, as class id -> what in the trace shows it (in words,
        one line per actor or event); empty when none fits."""

    def classify(self, scenario: Scenario, trace: Trace) -> list[str]:
        """The ids of the classes the scenario shows, in the typology's order; [] when none fits."""
        found = self.explain(scenario, trace)
        return [c.id for c in self.classes if c.id in found]

    def behavior_key(self, behavior: Behavior) -> str | None:
        """The domain's name of the robot behavior ``behavior`` shows (what
        :attr:`TypologyCause.fits` lists); None when it has none. Default: None."""
        return None

    def fill_causes(self, behavior: Behavior, class_id: str) -> list[str]:
        """Cause texts that present the class and fit ``behavior`` (none for a class the domain
        cannot simulate, or a behavior :meth:`behavior_key` does not name)."""
        c = self.get(class_id)
        key = self.behavior_key(behavior)
        if not c.simulable or key is None:
            return []
        return [cause.text for cause in c.causes if key in cause.fits]


class DomainBackend(ABC):
    """What a simulation domain provides to the pipeline.

    Class attributes are the domain's declarations; methods are the stages the pipeline calls
    (:mod:`regen.pipeline`), in order: ``ground`` -> ``simulate`` -> ``verify`` -> ``render`` ->
    ``export``. Only ``ground``, ``simulate`` and ``render`` (and the declarations) are required.
    An optional part that takes more than one method is a capability object the backend returns,
    None when the domain has none: :meth:`policy_harness` (``regen test``), :meth:`importer`
    (``regen import``), :meth:`recorder` (``regen generate --ego-trajectory``), :meth:`typology`
    (``regen eval --coverage``).
    """

    #: The domain's name, as users type it after ``--domain``.
    name: ClassVar[str]
    #: The asset database: (package, resource path inside it).
    database_resource: ClassVar[tuple[str, str]]
    #: The domain's words in the shared prompts.
    wording: ClassVar[Wording]
    #: The model of the domain's behavior parameters (``Behavior.params``), unknown keys refused;
    #: the base model takes none.
    params_model: ClassVar[type[BehaviorParams]] = BehaviorParams
    #: Module that registers the domain's predicates when imported (None: shared ones only).
    predicates_module: ClassVar[str | None] = None
    #: Labeled edge-construction examples shipped with the domain (package, resource), if any.
    edge_examples: ClassVar[tuple[str, str] | None] = None
    #: Labeled cause texts for ``regen eval --fidelity <domain>`` shipped with the domain
    #: (package, resource; :mod:`regen.evaluation.fidelity_set`), if any.
    fidelity_set: ClassVar[tuple[str, str] | None] = None
    #: Captions for the report.
    report_hints: ClassVar[ReportHints] = ReportHints()
    #: Gymnasium environments over this domain's scenarios: env id -> entry point
    #: ('package.module:Class'); :mod:`regen.gym` registers those of every registered domain.
    gym_envs: ClassVar[dict[str, str]] = {}

    def database(self) -> AssetDatabase:
        """The asset database of this domain's simulator."""
        from regen.assets.database import load_packaged_database

        package, resource = self.database_resource
        return load_packaged_database(package, resource)

    def params(self, behavior: Behavior) -> BehaviorParams:
        """The behavior's parameters as :attr:`params_model`; :class:`ConfigError` naming a key
        the domain does not take or a bad value."""
        return self.params_model.of(behavior)

    def check_behavior(self, behavior: Behavior) -> None:
        """Raise :class:`ConfigError` (saying what to do) when the behavior cannot run in this
        domain, before any model call is spent: a parameter of another domain, or one naming
        something the domain does not have, say. Default: the parameters fit :attr:`params_model`."""
        self.params(behavior)

    def property_choices(self, asset: str, behavior: Behavior | None = None) -> PropertyChoices | None:
        """The properties of ``asset`` whose values the simulator restricts
        (:class:`PropertyChoices`), or None. ``behavior``: the behavior being explained.
        Default: no restrictions."""
        return None

    def own_objects(self, behavior: Behavior) -> frozenset[str]:
        """Assets that belong to the robot's own task in ``behavior`` (the door it opens): never
        a cause's entity, since a cause must be shown by the world around the task. Default:
        none."""
        return frozenset()

    def settings_key(self, behavior: Behavior) -> dict[str, str | None]:
        """Behavior fields that change results in this domain (recorded and compared on resume)."""
        return {}

    def recorder(self) -> Recorder | None:
        """How ``regen generate --ego-trajectory`` reads a recorded trajectory of the robot
        (:class:`Recorder`); None: the domain takes none (give the behavior as text)."""
        return None

    def importer(self) -> Importer | None:
        """How ``regen import`` reads files another tool wrote into this domain's scenarios
        (:class:`Importer`); None: the domain imports none."""
        return None

    def write_episodes(self, run_dirs: list[Path], out: Path) -> dict[str, Any]:
        """Write the verified scenarios of ``run_dirs`` (this domain's runs) as robot-learning
        episodes at ``out`` (``regen dataset --format lerobot``); what was written, and under
        ``check`` a ``note`` saying how a reader of the format was run over it (or why not), which
        the command prints. Default: ConfigError, the domain writes none."""
        from regen.errors import ConfigError

        raise ConfigError(f"the {self.name} domain writes no robot-learning episodes (--format lerobot)")

    def typology(self) -> Typology | None:
        """The standard scenario typology of this domain and its rules (:class:`Typology`;
        ``regen eval --coverage``); None: the domain has none."""
        return None

    def dataset_views(self) -> DatasetViews | None:
        """What ``regen dataset`` draws and reads for this domain (:class:`DatasetViews`); None:
        the domain gives no vision-language-action samples."""
        return None

    @abstractmethod
    def ground(self, path: CausePath, llm: LLM | None, *, seed: int = 0) -> Scenario:
        """Turn a cause path into a scenario with an FSM and solved parameters.

        ``llm=None`` grounds with the domain's rules only. A malformed model answer may fall back
        to rules (recorded in ``scenario.fallbacks``); any other model error (replay miss,
        provider unreachable, bad model file) must propagate. An unsatisfiable scenario is
        returned with ``solver.status == 'infeasible'`` and the conflicts named; a path that
        cannot be grounded raises :class:`regen.errors.GroundingError` with the reason.
        """

    @abstractmethod
    def simulate(self, scenario: Scenario, workdir: Path) -> SimulationOutput:
        """Run the scenario; raise :class:`regen.errors.SimulationError` on simulator failure."""

    def verify(self, scenario: Scenario, trace: Trace) -> tuple[Verdict, Scenario]:
        """The verdict of the FSM monitor, with over-strict stages relaxed (and recorded); returns
        the scenario whose FSM the verdict is about."""
        from regen.verify.relax import verify_with_relaxation

        return verify_with_relaxation(scenario, trace)

    @abstractmethod
    def render(self, scenario: Scenario, trace: Trace, verdict: Verdict, out_dir: Path) -> dict[str, Path]:
        """Pictures of the run written into ``out_dir``, as role -> path (``animation`` and
        ``keyframes`` are shown by the report)."""

    #: The keyword options :meth:`export` takes (``regen generate`` passes them from the run's
    #: settings), as option -> what it does; an option a domain does not list is refused.
    export_options: ClassVar[dict[str, str]] = {}

    def export(self, scenario: Scenario, out_dir: Path, trace: Trace | None = None, **options: bool
               ) -> dict[str, Path]:
        """Files other simulators load (Scenic, OpenSCENARIO, ...) as role -> path, given the
        run's trace when there is one, with the :attr:`export_options` given. Optional."""
        return {}

    def policy_harness(self) -> PolicyHarness | None:
        """How ``regen test`` runs a policy in this domain's scenarios
        (:class:`regen.harness.contract.PolicyHarness`); None: the domain tests no policies."""
        return None

    def reference_world(self, scenario: Scenario, cause: list[str]) -> ReferenceWorld:
        """The scenario's world with the domain's reference robot, for the but-for check of
        ``cause`` (entity names; :mod:`regen.verify.causal`). Default: raises
        :class:`~regen.verify.causal.NotCheckable` (the domain has no reference robot)."""
        from regen.verify.causal import NotCheckable

        raise NotCheckable(f"the {self.name} domain has no reference robot to check causes with")

    def warm(self) -> float:
        """Do the once-per-process work of a first simulation (imports, the simulator's world
        model) ahead of it, in a process that has simulated nothing yet; the seconds it took. A
        batch does it while its first behaviors are still expanded: in the pool's zygote, which
        then forks the workers (so it must leave no thread running and no simulator connection
        open: the workers would share them), or in each Ray worker. Default: nothing."""
        return 0.0

    def config(self, scenario: Scenario) -> dict:
        """The scenario in the paper's config form (narrative, entities, vehicles, fsm)."""
        return {"narrative": scenario.narrative, "causal_graph": scenario.causal_graph,
                "fsm": scenario.fsm.as_tuples()}


__all__ = ["ANIMATION", "KEYFRAMES", "ROBOT_ORDERS", "Allowed", "DatasetViews", "DomainBackend", "Importer", "PropertyChoices",
           "RecordedBehavior", "Recorder", "ReportHints", "SimulationOutput", "Typology", "TypologyCause",
           "TypologyClass", "Wording"]
