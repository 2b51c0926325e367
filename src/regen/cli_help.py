"""How the ``regen`` command line reads: its help pages, their examples, the version, and the
wording of the options several commands share (one text per meaning, so that ``--llm``,
``--replay`` or ``--pictures`` are explained the same way wherever they appear).

:class:`RegenCommand` and :class:`RegenGroup` render the help of every command: a flag is shown
as a flag (``--replay``, ``--pictures/--no-pictures``), never as an option taking a ``<bool>``;
a positional argument by its name in capitals (``RUN_DIR``), never in braces; and the command's
examples (:data:`EXAMPLES`) close the page.

Imports: typer and rich only.
"""

from __future__ import annotations

from typing import Any

from rich.markup import escape
from typer.core import TyperArgument, TyperCommand, TyperGroup, TyperOption

#: The models ``--llm`` takes, as every command's help words them.
LLM_MODELS = "local (offline default), local:<alias or .gguf>, openai:<model>, anthropic:<model>"
LLM_KEYS = ("openai needs OPENAI_API_KEY (any compatible server via REGEN_OPENAI_BASE_URL, which gets "
            "REGEN_OPENAI_API_KEY or no key, never OPENAI_API_KEY), anthropic needs ANTHROPIC_API_KEY")
LLM_HELP = f"The model: {LLM_MODELS}; {LLM_KEYS}"


def llm_help(role: str) -> str:
    """``--llm`` of a command whose model does ``role`` ('that proposes the edits')."""
    return f"The model {role}: {LLM_MODELS} (keys as for regen generate)"


REPLAY_HELP = "Use only the model's answers cached by an earlier run; never call the model"
FRESH_HELP = "Discard an earlier run in --out instead of resuming it"
RUN_OUT_HELP = "Run folder to write (rerun the same command to resume)"
PICTURES_HELP = "Draw each scenario's GIF and key frames; --no-pictures is faster"
DOMAIN_METAVAR = "<domain>"
FILE_METAVAR = "<file>"
FOLDER_METAVAR = "<folder>"
MODEL_METAVAR = "<model>"
CANDIDATE_HELP = ("A cause of the behavior for the model to judge with its own (repeatable); a "
                  "rejected one stays in the graph with the judge's reason")
CAUSE_HELP = ("A cause of the behavior to accept whatever the judge says (repeatable); the judge's "
              "opinion is recorded, then it is expanded to entities and properties like any other")
TRAJECTORY_HELP = ("Driving: a recorded ego trajectory (CSV with a header t,x,y and optional heading,speed; "
                   "metres in the ego's start frame, x forward, y left, or map coordinates with --map) as the "
                   "behavior; the ego replays it exactly in every scenario")
LLM_TIMEOUT_HELP = ("Seconds to wait for one request to a remote model before retrying it (4 tries "
                    "in all); default: REGEN_LLM_TIMEOUT, else 120")

STOP = "'the ego-vehicle stops abruptly'"
SCENARIO = "runs/stop/scenarios/01-a-child-runs-across-the-road"
#: Examples of each command, by its path below ``regen``: the last part of its help page.
EXAMPLES: dict[str, list[str]] = {
    "": [f"regen generate {STOP} --domain driving --out runs/stop", "regen runs show runs/stop",
         "regen test runs/stop --policy idm", "regen generate --help"],
    "assets": ["regen assets driving", "regen assets manipulation --json"],
    "predicates": ["regen predicates", "regen predicates driving"],
    "expand": [f"regen expand {STOP} --domain driving --out runs/graph",
               f"regen expand {STOP} -d driving -o runs/graph --depth 2 --prior 'police car'"],
    "generate": [f"regen generate {STOP} --domain driving --out runs/stop",
                 "regen generate 'the robot opens the door' -d manipulation -o runs/door -n 5 --no-pictures",
                 f"regen generate {STOP} -d driving -o runs/stop-gpt --llm openai:gpt-4o",
                 "regen generate --domain driving --ego-trajectory drive.csv --out runs/recorded"],
    "batch": ["regen batch examples/batch.yaml --out runs/batch",
              "regen batch examples/batch.yaml --out runs/batch --workers 4",
              "regen batch examples/batch.yaml --out runs/batch --ray 127.0.0.1:6379"],
    "whatif": [f"regen whatif {SCENARIO} --set child1.behavior=wait_at_curb",
               f"regen whatif {SCENARIO} --ask 'what if the child stayed on the sidewalk?'"],
    "augment": [f"regen augment {SCENARIO}", f"regen augment {SCENARIO} --out augmented --no-judge"],
    "eval": ["regen eval runs/stop runs/door --out eval", "regen eval --list-examples",
             "regen eval example:regen_style_driving example:nhtsa_style --no-embeddings"],
    "test": ["regen test runs/stop --policy idm", "regen test runs/stop --policy my_policy.py:policy --variants 8",
             "regen test runs/stop --policy aeb --adversarial --out results/aeb"],
    "falsify": ["regen falsify runs/stop --policy idm --budget 24",
                "regen falsify runs/stop --policy my_policy.py --budget 60 --llm local --out results/falsify"],
    "import": ["regen import scenario.xosc --out runs/imported",
               "regen import scenario.xosc --out runs/imported --domain driving --no-pictures"],
    "dataset": ["regen dataset runs/stop --out datasets/stop",
                "regen dataset runs/batch/* --out datasets/vla --format llava"],
    "probe": ["regen probe datasets/stop --llm local",
              "regen probe datasets/stop --llm openai:gpt-4o --layers planning,counterfactual",
              "regen probe datasets/stop --llm openai:gpt-4o --text-only --limit 20"],
    "model": ["regen model status", "regen model prepare"],
    "model status": ["regen model status"],
    "model prepare": ["regen model prepare", "regen model prepare qwen2.5-coder-1.5b"],
    "model verify": ["regen model verify"],
    "runs": ["regen runs list runs", "regen runs show runs/stop"],
    "runs list": ["regen runs list", "regen runs list runs"],
    "runs show": ["regen runs show runs/stop"],
}


def examples(path: str) -> str:
    """The epilog of the command ``regen <path>``: its examples, one a line (rich markup)."""
    return "[bold]Examples:[/]\n" + "\n".join(f"  {escape(line)}" for line in EXAMPLES[path])


def help_for(path: str) -> dict[str, Any]:
    """Keyword arguments of ``app.command`` for the command ``regen <path>``: its class and examples."""
    return {"cls": RegenCommand, "epilog": examples(path)}


def group_help(path: str) -> dict[str, Any]:
    """Keyword arguments of ``typer.Typer`` for the group ``regen <path>``: its class and examples."""
    return {"cls": RegenGroup, "epilog": examples(path)}


def package_version() -> str:
    """The installed distribution's version (pyproject's ``[project] name``), else ``regen.__version__``."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("regen-sim")
    except PackageNotFoundError:
        import regen

        return str(getattr(regen, "__version__", "unknown"))


def _named(params: list[Any]) -> None:
    """A flag gets no value placeholder (typer would show ``<bool>``); an argument is named in capitals."""
    for p in params:
        if isinstance(p, TyperOption) and p.is_flag and p.metavar is None:
            p.metavar = ""
        elif isinstance(p, TyperArgument) and p.metavar is None and p.name:
            p.metavar = p.name.upper()


def _usage(self: Any, ctx: Any) -> list[str]:
    """The usage line's pieces: ``[OPTIONS] RUN_DIR`` (an optional argument in brackets, a repeatable
    one followed by ``...``), where typer would write ``{run_dir}``."""
    pieces = [self.options_metavar] if self.options_metavar else []
    for p in self.get_params(ctx):
        if not isinstance(p, TyperArgument):
            pieces.extend(p.get_usage_pieces(ctx))
            continue
        name = p.metavar or (p.name or "ARG").upper()
        pieces.append((name if p.required else f"[{name}]") + ("..." if p.nargs != 1 else ""))
    return pieces


class NamedParams:
    """Mixed into a command or group: flags shown as flags and arguments by name (see the module)."""

    params: list[Any]

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        _named(self.params)

    def get_help_option(self, ctx: Any) -> Any:
        option = super().get_help_option(ctx)  # type: ignore[misc]
        if option is not None:
            _named([option])
        return option


class RegenCommand(NamedParams, TyperCommand):
    """A command whose help shows flags as flags and arguments by name (see the module)."""

    def collect_usage_pieces(self, ctx: Any) -> list[str]:
        return _usage(self, ctx)


class RegenGroup(NamedParams, TyperGroup):
    """A group of commands whose help shows flags as flags (see the module)."""


__all__ = ["CANDIDATE_HELP", "CAUSE_HELP", "DOMAIN_METAVAR", "EXAMPLES", "FILE_METAVAR", "FOLDER_METAVAR",
           "FRESH_HELP", "LLM_HELP", "LLM_MODELS", "LLM_TIMEOUT_HELP", "MODEL_METAVAR", "PICTURES_HELP", "REPLAY_HELP",
           "RUN_OUT_HELP", "NamedParams", "RegenCommand", "RegenGroup", "TRAJECTORY_HELP", "examples", "group_help",
           "help_for", "llm_help", "package_version"]
