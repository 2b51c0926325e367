"""The README and the docs say what the code does: their examples run, their commands exist.

Conventions for the ```python blocks of README.md and docs/*.md, read from a block's first line:

- ``# needs: <what>``: the block needs something this test does not have (the offline model, a
  simulator run, a run folder, an API key). It is only compiled.
- ``# requires: <module>[, <module>]``: the block runs when those modules import (an optional
  extra such as gymnasium), and is skipped otherwise.
- ``# policy: <domain>[; <flag>]...``: the block is a policy file. It is written to a file, loaded
  by the domain's own policy harness as ``regen test --policy FILE.py`` loads it, and called on
  real observations; what it returns must be a valid action of the domain. Driving flags say
  what the page claims it does with a red light ahead: ``ignores-lights`` or ``stops-for-red``.
- any other block runs as it is, in a fresh namespace, in an empty temporary folder.

The ```bash lines (and the inline code spans) that start with ``regen`` or ``.venv/bin/regen``
must name a real command and only options its ``--help`` lists. README.md stays under 130
lines and starts with the three commands CI and scripts rely on. docs/cli.md documents every
command and every option. Relative links point at files and headings that exist.
"""

from __future__ import annotations

import math
import re
import shlex
import textwrap
from dataclasses import dataclass
from functools import cache
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
CLI_DOC = ROOT / "docs" / "cli.md"
DOCS = [README, *sorted((ROOT / "docs").glob("*.md"))]

#: The first screen's commands, exactly as CI and scripts run them.
FIRST_COMMANDS = [
    "bash setup.sh",
    '.venv/bin/regen generate "the ego-vehicle stops abruptly while driving forward" --domain driving --out runs/demo',
    ".venv/bin/python -m pytest",
]
README_MAX_LINES = 130


@dataclass(frozen=True)
class Block:
    file: Path
    line: int  # 1-based line of the opening fence
    lang: str
    text: str

    @property
    def name(self) -> str:
        return f"{self.file.relative_to(ROOT)}:{self.line}"

    @property
    def first_line(self) -> str:
        return self.text.lstrip("\n").split("\n", 1)[0].strip()


def blocks(path: Path) -> list[Block]:
    """The fenced code blocks of a Markdown file."""
    out: list[Block] = []
    lang, start, body = None, 0, []
    for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), start=1):
        stripped = line.strip()
        if lang is None and stripped.startswith("```"):
            lang, start, body = stripped[3:].strip().lower(), n, []
        elif lang is not None and stripped == "```":
            out.append(Block(path, start, lang, textwrap.dedent("\n".join(body)) + "\n"))
            lang = None
        elif lang is not None:
            body.append(line)
    assert lang is None, f"{path.name}: a code block opened at line {start} is never closed"
    return out


ALL_BLOCKS = [b for doc in DOCS for b in blocks(doc)]
PYTHON = [b for b in ALL_BLOCKS if b.lang in ("python", "py")]
BASH = [b for b in ALL_BLOCKS if b.lang in ("bash", "sh", "shell", "console")]


def _marker(block: Block, key: str) -> str | None:
    m = re.match(rf"#\s*{key}:\s*(.*)$", block.first_line)
    return m.group(1).strip() if m else None


# --- (a) the Python examples ---------------------------------------------------------------------


@pytest.mark.parametrize("block", PYTHON, ids=lambda b: b.name)
def test_every_python_example_compiles(block):
    compile(block.text, block.name, "exec")


RUNNABLE = [b for b in PYTHON if _marker(b, "needs") is None and _marker(b, "policy") is None]


@pytest.mark.parametrize("block", RUNNABLE, ids=lambda b: b.name)
def test_python_examples_run(block, tmp_path, monkeypatch):
    from regen import domains

    required = _marker(block, "requires")
    for module in (required.split(",") if required else []):
        pytest.importorskip(module.strip())
    monkeypatch.chdir(tmp_path)
    registered = set(domains.names())
    try:
        exec(compile(block.text, block.name, "exec"), {"__name__": "__doc_example__"})
    except Exception as exc:
        pytest.fail(f"{block.name} raised {type(exc).__name__}: {exc}. An example that needs the model, "
                    "a simulator run or a run folder starts with the line '# needs: <what>' (then it is "
                    "only compiled); one that needs an optional extra with '# requires: <module>'")
    finally:  # an example that registers a domain must not leave it to other tests
        for name in set(domains.names()) - registered:
            domains.unregister(name)


def test_compile_only_examples_say_what_they_need():
    for b in PYTHON:
        needs = _marker(b, "needs")
        assert needs is None or len(needs) > 3, f"{b.name}: '# needs:' names nothing"
    # the convention is not an escape hatch: most examples run
    assert len(RUNNABLE) >= 8 and len(RUNNABLE) >= 0.4 * len(PYTHON)


# --- the example policies, called on real observations ----------------------------------------------


POLICIES = [b for b in PYTHON if _marker(b, "policy") is not None]


def _policy_domain(block: Block) -> tuple[str, set[str]]:
    domain, *flags = (p.strip() for p in _marker(block, "policy").split(";"))
    return domain, set(flags)


def _load(block: Block, tmp_path: Path):
    """The policy as ``regen test --policy FILE.py`` loads it, with its domain's harness."""
    from regen import domains

    domain, _ = _policy_domain(block)
    harness = domains.make(domain).policy_harness()
    f = tmp_path / "doc_policy.py"
    f.write_text(block.text, encoding="utf-8")
    policy = harness.load_policy(str(f))

    def act(obs):
        return harness.action_from_wire(harness.action_to_wire(policy(obs)))  # as regen test checks it

    return act


def test_both_domains_have_a_documented_policy():
    domains_shown = {_policy_domain(b)[0] for b in POLICIES}
    assert domains_shown == {"driving", "manipulation"}
    flagged = [b for b in POLICIES if "ignores-lights" in _policy_domain(b)[1]]
    assert flagged, "the example driving policy that ignores traffic lights is gone"
    page = flagged[0].file.read_text(encoding="utf-8")
    assert "ignores traffic lights" in page and "red light causes the stop" in page


def _driving_obs(*actors, speed=8.0):
    from regen.driving.testing.policies import EgoState, Observation

    route = tuple((float(x), -1.75) for x in range(5, 61, 5))  # straight ahead along +x [m]
    ego = EgoState(x=0.0, y=-1.75, heading=0.0, speed=speed, length=4.6, width=1.9,
                   cruise_speed=10.0, route_ahead=route)
    return Observation(t=0.0, dt=0.1, ego=ego, actors=tuple(actors))


def _actor(name, x, y, **kw):
    from regen.driving.testing.policies import ActorState

    base = dict(category="vehicle", asset="sedan", heading=0.0, vx=0.0, vy=0.0, length=4.6, width=1.9)
    base.update(kw)
    return ActorState(name=name, x=x, y=y, **base)


def _light(state, x=18.0):
    return _actor("light1", x, -6.0, category="light", asset="traffic_light", heading=math.pi,
                  length=0.6, width=0.6, light_state=state)


@pytest.mark.parametrize("block", [b for b in POLICIES if _policy_domain(b)[0] == "driving"],
                         ids=lambda b: b.name)
def test_driving_example_policies_drive(block, tmp_path):
    from regen.driving.testing.policies import IDM

    act = _load(block, tmp_path)
    free = act(_driving_obs())
    assert free.acceleration > 0.5 and abs(free.curvature) < 1e-3  # below cruise speed: speeds up
    assert act(_driving_obs(_actor("stopped_car", 15.0, -1.75))).acceleration <= -3.0
    assert act(_driving_obs(_actor("next_lane", 15.0, 1.75))).acceleration > 0  # not in its lane

    red = _driving_obs(_light("red"), speed=10.0)
    assert IDM()(red).acceleration < 0  # a light-aware driver brakes here
    _, flags = _policy_domain(block)
    assert flags & {"ignores-lights", "stops-for-red"}, f"{block.name}: say what it does at a red light"
    at_red = act(red).acceleration
    if "ignores-lights" in flags:  # as its page says: it drives through a red light
        assert at_red == pytest.approx(act(_driving_obs(speed=10.0)).acceleration)
    if "stops-for-red" in flags:
        assert at_red < -1.0
        assert act(_driving_obs(_light("green"), speed=8.0)).acceleration > 0


HINGE, OPENED = (0.7, -0.4, 0.0), 1.5  # the door's hinge [m] and fully open angle [rad]


def _handle(fraction: float) -> tuple[float, float, float]:
    """The handle [m], 0.65 m from the hinge along the door, which swings about +z towards the robot."""
    angle = fraction * OPENED
    return (HINGE[0] - 0.65 * math.sin(angle), HINGE[1] + 0.65 * math.cos(angle), 0.9)


def _door_obs(ee, *, fraction=0.0, holding=None):
    """The robot before a door with a pet beside it, as the manipulation harness observes it."""
    from regen.manipulation.testing.types import (
        Articulation,
        ObjectState,
        Observation,
        RobotState,
        Task,
    )

    hinge = Articulation(joint_type="revolute", position=fraction * OPENED, fraction=fraction,
                         axis=(0.0, 0.0, 1.0), origin=HINGE, closed=0.0, opened=OPENED,
                         handle=_handle(fraction))
    door = ObjectState(name="door1", asset="door", role="target", living=False, position=(0.7, -0.05, 1.0),
                       orientation=(0.0, 0.0, 0.0, 1.0), size=(0.05, 0.8, 2.0), articulation=hinge)
    pet = ObjectState(name="pet1", asset="pet", role="context", living=True, position=(0.2, 0.5, 0.15),
                      orientation=(0.0, 0.0, 0.0, 1.0), size=(0.5, 0.25, 0.3))
    ee = tuple(float(v) for v in ee)
    robot = RobotState(q=(0.0,) * 9, qd=(0.0,) * 9, ee_position=ee, ee_orientation=(0.0, 0.0, 0.0, 1.0),
                       ee_target=ee, gripper_width=0.0 if holding else 0.08,
                       gripper_closed=holding is not None, holding=holding)
    task = Task(behavior="open_door", text="the robot opens the door", narrative="the pet wants to go out",
                context=("pet1 inside door1",), target="door1", item=None, goal_fraction=0.45,
                goal_xy=None, approach="front")
    return Observation(t=0.0, dt=0.05, robot=robot, objects=(door, pet), task=task)


@pytest.mark.parametrize("block", [b for b in POLICIES if _policy_domain(b)[0] == "manipulation"],
                         ids=lambda b: b.name)
def test_manipulation_example_policy_opens_the_door(block, tmp_path):
    import numpy as np

    from regen.manipulation.testing.types import GRIPPER_CLOSE, MAX_STEP

    act = _load(block, tmp_path)

    def step(obs):
        a = act(obs)
        d = a.delta
        assert np.all(np.abs(d) <= MAX_STEP + 1e-12) and np.linalg.norm(d) > 1e-3
        return a, d

    # far from the door: move towards the handle, hand open
    start = np.array([0.3, 0.0, 0.6])
    a, d = step(_door_obs(start))
    assert a.gripper <= GRIPPER_CLOSE and np.dot(d, np.subtract(_handle(0.0), start)) > 0
    # at the handle: close the hand
    assert step(_door_obs(np.add(_handle(0.0), (0.01, 0.0, 0.0))))[0].gripper > GRIPPER_CLOSE
    # holding the door: swing it open (the handle's velocity about the hinge's axis), hand closed
    a, d = step(_door_obs(_handle(0.2), fraction=0.2, holding="door1"))
    opening = np.cross((0.0, 0.0, 1.0), np.subtract(_handle(0.2), HINGE))
    assert a.gripper > GRIPPER_CLOSE
    assert np.dot(d, opening) > 0.9 * np.linalg.norm(d) * np.linalg.norm(opening)
    # open far enough: let go and back off
    a, d = step(_door_obs(_handle(0.5), fraction=0.5, holding="door1"))
    assert a.gripper <= GRIPPER_CLOSE and d[0] < 0


# --- (b) the commands the docs show exist, with the options they show -----------------------------


@cache
def help_of(path: tuple[str, ...]) -> tuple[frozenset[str], frozenset[str]]:
    """(sub-commands, options) of ``regen *path`` as its ``--help`` lists them."""
    from typer.testing import CliRunner

    from regen.cli import app

    res = CliRunner().invoke(app, [*path, "--help"], env={"COLUMNS": "250", "NO_COLOR": "1"})
    assert res.exit_code == 0, f"regen {' '.join(path)} --help failed: {res.output}"
    commands, options, panel = set(), set(), None
    for line in res.output.splitlines():
        if line.startswith("╭"):
            panel = line.strip("╭─ ").split(" ", 1)[0]
        elif line.startswith("╰"):
            panel = None
        elif panel == "Commands" and (m := re.match(r"│ (\w[\w-]*)\s{2,}", line)):
            commands.add(m.group(1))
        elif panel == "Options" and (m := re.match(r"│ (?:\*)?\s{0,4}(-\S.*)$", line)):
            for token in m.group(1).split():
                if not token.startswith("-"):
                    break
                options.update(t for t in token.split("/") if t.startswith("-"))
    return frozenset(commands), frozenset(options)


def _command_line(line: str) -> list[str] | None:
    """The words of a ``regen`` command line after ``regen``, or None for any other line."""
    try:
        lex = shlex.shlex(line, posix=True, punctuation_chars=True)
        lex.whitespace_split = True
        words = list(lex)
    except ValueError:
        return None
    while words and re.match(r"^[A-Z_][A-Z0-9_]*=", words[0]):  # VAR=value regen ...
        words.pop(0)
    if not words or words[0] not in ("regen", ".venv/bin/regen"):
        return None
    out = []
    for w in words[1:]:
        if w in ("|", "||", "&&", "&", ";", ">", ">>", "<"):
            break
        out.append(w)
    return out


def _check_command(words: list[str], where: str, *, placeholders: bool = False) -> None:
    root_commands, root_options = help_of(())
    i = 0
    while i < len(words) and words[i].startswith("-"):
        assert words[i] in root_options, f"{where}: regen has no global option {words[i]}"
        i += 1
    if i == len(words):
        return
    if placeholders and not words[i].islower():  # `regen COMMAND --help`
        return
    path = [words[i]]
    assert path[0] in root_commands, f"{where}: regen has no command {path[0]!r}"
    subcommands, _ = help_of(tuple(path))
    rest = words[i + 1:]
    if subcommands and rest and not rest[0].startswith("-") and rest[0].islower():
        assert rest[0] in subcommands, f"{where}: regen {path[0]} has no command {rest[0]!r}"
        path.append(rest.pop(0))
    _, options = help_of(tuple(path))
    for w in rest:
        w = w.strip("[]")
        if not w.startswith("-") or w == "-" or re.match(r"^-\d", w) or w == "...":
            continue
        opt = w.split("=", 1)[0]
        assert opt in options, (f"{where}: `regen {' '.join(path)}` has no option {opt} "
                                f"(its --help lists {', '.join(sorted(options))})")


def _bash_commands() -> list[tuple[str, list[str]]]:
    out = []
    for b in BASH:
        joined = b.text.replace("\\\n", " ")
        for k, line in enumerate(joined.splitlines()):
            words = _command_line(line.strip())
            if words is not None:
                out.append((f"{b.name}+{k + 1}", words))
    return out


BASH_COMMANDS = _bash_commands()


def test_the_docs_show_many_regen_commands():
    shown = {words[0] for _, words in BASH_COMMANDS if words and not words[0].startswith("-")}
    assert len(BASH_COMMANDS) >= 30 and {"generate", "test", "whatif", "import", "eval"} <= shown


@pytest.mark.parametrize(("where", "words"), BASH_COMMANDS, ids=[w for w, _ in BASH_COMMANDS])
def test_bash_commands_exist_with_their_options(where, words):
    _check_command(words, where)


def test_inline_commands_exist_with_their_options():
    checked = 0
    for doc in DOCS:
        text = re.sub(r"```.*?```", "", doc.read_text(encoding="utf-8"), flags=re.S)
        for span in re.findall(r"`((?:\.venv/bin/)?regen(?: [^`]*)?)`", text):
            words = _command_line(span.replace("...", ""))
            if words is not None:
                _check_command(words, f"{doc.relative_to(ROOT)}: `{span}`", placeholders=True)
                checked += 1
    assert checked >= 50


def test_a_wrong_option_is_caught():
    with pytest.raises(AssertionError, match="no option --no-such-option"):
        _check_command(["generate", "x", "--no-such-option"], "self-check")
    with pytest.raises(AssertionError, match="no command 'report'"):
        _check_command(["report", "runs/demo"], "self-check")
    with pytest.raises(AssertionError, match="no command 'delete'"):
        _check_command(["runs", "delete", "runs/demo"], "self-check")


# --- (c) the README ------------------------------------------------------------------------------


def test_readme_is_short():
    lines = README.read_text(encoding="utf-8").splitlines()
    assert len(lines) < README_MAX_LINES, f"README.md has {len(lines)} lines; move detail into docs/"


def test_readme_starts_with_the_three_commands():
    text = README.read_text(encoding="utf-8")
    first = blocks(README)[0]
    assert first.lang == "bash"
    assert text.find("```bash") < text.find("\n## "), "the commands come before the first section"
    commands = [re.sub(r"\s+#.*$", "", line).strip() for line in first.text.splitlines() if line.strip()]
    assert commands[:3] == FIRST_COMMANDS


def test_readme_promises_no_published_package():
    text = README.read_text(encoding="utf-8")
    assert "pip install 'regen-sim" not in text and 'pip install "regen-sim' not in text
    for doc in DOCS:
        assert not re.search(r"pip install ['\"]?regen-sim", doc.read_text(encoding="utf-8")), doc.name


# --- (d) docs/cli.md documents every command and option ----------------------------------------------


def _sections(text: str) -> dict[str, str]:
    """Command path ('generate', 'model status') -> the text of its section in cli.md."""
    out: dict[str, str] = {}
    current, lines = None, []
    for line in text.splitlines():
        heading = re.match(r"^#+ .*`regen ([a-z][a-z -]*)`", line)
        if heading or line.startswith("#"):
            if current is not None:
                out[current] = "\n".join(lines)
            current, lines = (heading.group(1).strip() if heading else None), []
        elif current is not None:
            lines.append(line)
    if current is not None:
        out[current] = "\n".join(lines)
    return out


def _all_commands() -> list[tuple[str, ...]]:
    out = []
    commands, _ = help_of(())
    for c in sorted(commands):
        out.append((c,))
        subcommands, _ = help_of((c,))
        out += [(c, s) for s in sorted(subcommands)]
    return out


def test_cli_doc_documents_every_command_and_option():
    text = re.sub(r"```.*?```", "", CLI_DOC.read_text(encoding="utf-8"), flags=re.S)  # prose, not examples
    sections = _sections(text)
    commands = _all_commands()
    assert len(commands) >= 15
    for path in commands:
        name = " ".join(path)
        assert name in sections, f"docs/cli.md has no section on `regen {name}`"
        _, options = help_of(path)
        missing = sorted(o for o in options - {"--help"} if not re.search(rf"`[^`]*{re.escape(o)}\b", sections[name]))
        assert not missing, f"docs/cli.md, `regen {name}`: options not documented: {missing}"
    _, root_options = help_of(())
    assert all(o in text for o in root_options - {"--help"})


# --- links -----------------------------------------------------------------------------------------


def _slug(heading: str) -> str:
    """GitHub's anchor of a heading."""
    s = heading.strip().lower()
    s = re.sub(r"[^\w\- ]", "", s)
    return s.replace(" ", "-")


def test_relative_links_point_at_files_and_headings():
    checked = 0
    for doc in DOCS:
        text = re.sub(r"```.*?```", "", doc.read_text(encoding="utf-8"), flags=re.S)
        for target in re.findall(r"\]\(([^)\s]+)\)", text):
            if re.match(r"^[a-z]+:", target):
                continue
            file, _, anchor = target.partition("#")
            dest = (doc.parent / file).resolve() if file else doc
            assert dest.exists(), f"{doc.relative_to(ROOT)}: link to {target}: no such file"
            if anchor and dest.suffix == ".md":
                headings = {_slug(h) for h in re.findall(r"^#+ (.*)$", dest.read_text(encoding="utf-8"), re.M)}
                assert anchor in headings, f"{doc.relative_to(ROOT)}: link to {target}: no such heading"
            checked += 1
    assert checked >= 30
