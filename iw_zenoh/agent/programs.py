"""What ``iwz agent PROGRAM`` runs: a program that ships (a module of ``iw_zenoh.agents``), or
one from the user's own file (``./my_agent.py`` or ``./my_agent.py:Name``).

A program adds its options to a parser (``add_arguments(parser)``, optional in a user's file) and
makes its agents from the parsed arguments. In a user's file the maker is ``make``, or the
object ``Name`` names: an agent class or a function, called with the parsed arguments when it
takes a parameter and with none otherwise, that returns an agent or a list of agents (an object
with ``spec()`` and ``on_sensors(reading, heard)``, see :mod:`iw_zenoh.agent`); or an agent
object itself.

Whatever goes wrong with a user's file is a :class:`ProgramError` that says what and where: the
file missing, an import error (its line in the user's file and the error), no such name, or an
object of the wrong kind.
"""

from __future__ import annotations

import argparse
import difflib
import importlib
import importlib.util
import inspect
import json
import pkgutil
import sys
import traceback
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import Any

from iw_zenoh.agent import Agent, Command
from iw_zenoh.core.spec import RobotSpec
from iw_zenoh.errors import ConfigError, IwError
from iw_zenoh.messages import Heard, SensorReading
from iw_zenoh.scenario.specfile import SPEC_TABLE, apply_spec, load_spec_file

__all__ = [
    "Program",
    "ProgramError",
    "add_seed_argument",
    "add_spec_arguments",
    "available",
    "find_program",
    "is_file_program",
    "make_with_spec",
    "program_label",
]

DEFAULT_MAKER = "make"  # what a user's file is asked for when its name is not given


class ProgramError(IwError):
    """An agent program that cannot be found, loaded or made; the message says what and where."""


@dataclass(frozen=True)
class Program:
    """An agent program.

    Attributes:
        name: As the user wrote it (``waypoint``, ``./my_agent.py:GoTo``).
        doc: Its description (the module's docstring).
        add_arguments: Adds its options to a parser.
        make: Its agents from the parsed arguments.
        from_file: Whether it is the user's own file.
    """

    name: str
    doc: str
    add_arguments: Callable[[argparse.ArgumentParser], None]
    make: Callable[[argparse.Namespace], list[Agent]]
    from_file: bool = False


def available() -> list[str]:
    """Names of the agent programs that ship."""
    package = importlib.import_module("iw_zenoh.agents")
    names = sorted(m.name for m in pkgutil.iter_modules(package.__path__) if not m.name.startswith("_"))
    # helper modules (the autopilot, the emulated chair) are not programs: a program has make()
    return [n for n in names if hasattr(importlib.import_module(f"iw_zenoh.agents.{n}"), "make")]


def is_file_program(text: str) -> bool:
    """Whether ``text`` names a user's file (``x.py``, ``./x.py:Name``, ``dir/x``) rather than a program that ships."""
    path = text.rsplit(":", 1)[0] if text.count(":") == 1 else text
    return path.endswith(".py") or "/" in path or "\\" in path


def program_label(text: str) -> str:
    """A program's name as a process name takes it: a user's file by its stem (``./go_to.py:GoTo``
    is ``go_to``), a program that ships as itself."""
    if not is_file_program(text):
        return text
    stem = Path(text.rsplit(":", 1)[0] if text.count(":") == 1 else text).stem
    return "".join(c if c.isalnum() or c in "-_" else "_" for c in stem) or "agent"


def find_program(text: str) -> Program:
    """The program ``text`` names.

    Args:
        text: A shipped program's name, or ``PATH.py[:Name]`` (relative to the working folder).

    Raises:
        ProgramError: Saying what is wrong and how to put it right.
    """
    if is_file_program(text):
        return _file_program(text)
    module = _shipped(text)
    if module is not None:
        return Program(text, module.__doc__ or "", module.add_arguments, module.make)
    names = available()
    if text not in names:
        close = difflib.get_close_matches(text, names, n=1)
        hint = f" (did you mean {close[0]!r}?)" if close else ""
        raise ProgramError(
            f"no agent program {text!r}{hint}; programs: {', '.join(names)}; "
            "or your own file: iwz agent ./my_agent.py:Name"
        )
    module = importlib.import_module(f"iw_zenoh.agents.{text}")
    return Program(text, module.__doc__ or "", module.add_arguments, module.make)


def _shipped(text: str) -> ModuleType | None:
    """The shipped program module ``text`` names, importing only it (not every program, so a
    process loads what its own program uses), or None when there is none of that name."""
    if not text.isidentifier() or text.startswith("_"):
        return None
    try:
        module = importlib.import_module(f"iw_zenoh.agents.{text}")
    except ModuleNotFoundError as e:
        if e.name != f"iw_zenoh.agents.{text}":
            raise  # the program exists but something it imports does not: say so, not "no such program"
        return None
    return module if hasattr(module, "make") else None


def _file_program(text: str) -> Program:
    """A program from the user's file ``PATH[:Name]``."""
    path_text, _, name = text.partition(":") if text.count(":") == 1 else (text, "", "")
    path = Path(path_text)
    if not path.is_file():
        where = path.resolve()
        raise ProgramError(f"{path_text}: no such file ({where}); give the path of a Python file, e.g. ./my_agent.py")
    module = _load(path)
    maker_name = name or DEFAULT_MAKER
    if not hasattr(module, maker_name):
        own = module.__name__
        defined = sorted(n for n, v in vars(module).items() if not n.startswith("_") and _module_of(v) == own)
        asked = f"no {name!r}" if name else f"no {DEFAULT_MAKER}(); name the agent: iwz agent {path_text}:Name"
        raise ProgramError(f"{path_text} has {asked} (it defines: {', '.join(defined) or 'nothing'})")
    maker = getattr(module, maker_name)
    label = f"{path_text}:{maker_name}"
    if not callable(maker) and not _is_agent(maker):
        raise ProgramError(f"{label} is {_kind(maker)}, not an agent class, an agent or a function that makes agents")
    add = getattr(module, "add_arguments", None)
    if add is not None and not callable(add):
        raise ProgramError(f"{path_text}: add_arguments is {_kind(add)}, not a function of an argparse parser")

    def make(args: argparse.Namespace) -> list[Agent]:
        return _agents(maker, args, maker_name, path)

    return Program(text, module.__doc__ or "", add or (lambda _p: None), make, from_file=True)


def _load(path: Path) -> ModuleType:
    """Imports the user's file as a module of its own name (its folder importable, for its helpers)."""
    name = f"iwz_user_{path.stem}".replace("-", "_")
    spec = importlib.util.spec_from_file_location(name, path)
    if spec is None or spec.loader is None:
        raise ProgramError(f"{path}: not a Python file Python can import (name it *.py)")
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module  # dataclasses and pickling look their module up here
    folder = str(path.resolve().parent)
    if folder not in sys.path:
        sys.path.insert(0, folder)
    try:
        spec.loader.exec_module(module)
    except SyntaxError as e:
        line = (e.text or "").rstrip()
        raise ProgramError(f"{path}, line {e.lineno}: {e.msg}" + (f"\n    {line.strip()}" if line else "")) from None
    except Exception as e:  # the user's code failed as it was imported: where, and why
        raise ProgramError(f"{path} could not be imported: {_where(e, path)}") from None
    return module


def _agents(maker: Any, args: argparse.Namespace, label: str, path: Path) -> list[Agent]:
    """Calls the user's maker (``label``: its name, for messages) and checks it made agents."""
    if _is_agent(maker) and not inspect.isclass(maker):
        return [maker]
    try:
        made = maker(args) if _takes_arguments(maker) else maker()
    except Exception as e:  # the user's code failed (a spec out of range too): where, and why
        raise ProgramError(f"{label}() failed: {_where(e, path)}") from None
    agents = list(made) if isinstance(made, list | tuple) else [made]
    bad = [a for a in agents if not _is_agent(a)]
    if bad or not agents:
        what = _kind(bad[0]) if bad else "no agent"
        raise ProgramError(
            f"{label} made {what}, not an agent: an agent has spec() -> Spec and "
            "on_sensors(reading, heard) -> Command (see docs/first-agent.md)"
        )
    for a in agents:  # its robot is asked for once the bus is up: a spec that fails, fails here
        try:
            spec = a.spec()
        except Exception as e:
            raise ProgramError(f"{label}(...).spec() failed: {_where(e, path)}") from None
        if not isinstance(spec, RobotSpec):
            raise ProgramError(f"{label}(...).spec() returned {_kind(spec)}, not a Spec (iw_zenoh.agent)")
    return agents


def _module_of(obj: object) -> str:
    return str(getattr(obj, "__module__", ""))


def _is_agent(obj: object) -> bool:
    return callable(getattr(obj, "spec", None)) and callable(getattr(obj, "on_sensors", None))


def _takes_arguments(maker: Any) -> bool:
    """Whether the maker wants the parsed arguments: it has a parameter without a default."""
    try:
        params = inspect.signature(maker).parameters.values()
    except (TypeError, ValueError):
        return False
    return any(
        p.default is p.empty and p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD, p.VAR_POSITIONAL)
        for p in params
    )


def _kind(obj: object) -> str:
    kind = type(obj).__name__
    return "None" if obj is None else f"{'an' if kind[0] in 'aeiouAEIOU' else 'a'} {kind}"


def _where(error: BaseException, path: Path) -> str:
    """``line N: code`` of the deepest frame in the user's file, and the error."""
    frames = [f for f in traceback.extract_tb(error.__traceback__) if Path(f.filename).resolve() == path.resolve()]
    said = f"{type(error).__name__}: {error}"
    if not frames:
        return said
    f = frames[-1]
    return f"line {f.lineno}, in {f.name}: {(f.line or '').strip()}\n    {said}"


def add_spec_arguments(parser: argparse.ArgumentParser) -> None:
    """``--spec FILE`` and ``--spec-json TABLE``: the robots' spec as data (every program has them)."""
    parser.add_argument(
        "--spec",
        metavar="FILE",
        default="",
        help="the chair as data: a spec file whose [chair] table sets any registration field "
        "(size, centre of movement, speed, sensors, noise...) of this program's robots (docs/spec.md)",
    )
    parser.add_argument(
        "--spec-json",
        metavar="TABLE",
        default="",
        help="the same table as JSON (what iwz run passes for a scenario's spec); over --spec's",
    )


def add_seed_argument(parser: argparse.ArgumentParser) -> None:
    """``--seed N``: the seed handed to the program's agents as ``args.seed`` (every program has it;
    one that declares its own ``--seed``, of the same meaning, keeps its own). ``iwz run`` gives
    each ``[[agents]]`` entry one (its ``seed``, or one drawn from the world's, docs/scenarios.md)."""
    if "--seed" not in parser._option_string_actions:  # argparse keeps no public registry of options
        parser.add_argument(
            "--seed",
            type=int,
            default=0,
            metavar="N",
            help="the agents' seed, args.seed: draw from np.random.default_rng(args.seed) (default 0)",
        )


def make_with_spec(program: Program, args: argparse.Namespace) -> list[Agent]:
    """The program's agents, their robots' spec changed by ``--spec`` and ``--spec-json``.

    The table is in ``args.spec_table`` (and its place, for refusals, in ``args.spec_where``), so a
    program applies it to the chair it builds (:func:`iw_zenoh.scenario.specfile.spec_with_args`) and drives
    the chair it registers; an agent whose spec does not have it yet (a user's) registers it anyway.

    Raises:
        ConfigError: A spec file or table refused, naming the field.
    """
    table: dict[str, Any] = {}
    where = []
    if args.spec:
        table.update(load_spec_file(args.spec))
        where.append(f"{args.spec}: {SPEC_TABLE}")
    if args.spec_json:
        try:
            given = json.loads(args.spec_json)
        except json.JSONDecodeError as e:
            raise ConfigError("--spec-json", f"not JSON: {e}") from None
        if not isinstance(given, dict):
            raise ConfigError("--spec-json", f"a table (JSON object) of spec fields, got {given!r}")
        table.update(given)
        where.append("spec")
    args.spec_table, args.spec_where = table, where[-1] if where else SPEC_TABLE
    agents = program.make(args)
    return [_with_spec(a, table, args.spec_where) for a in agents] if table else agents


class _WithSpec:
    """An agent whose robot is registered with the spec table laid over its own."""

    def __init__(self, agent: Agent, spec: RobotSpec) -> None:
        self._agent = agent
        self._spec = spec

    def spec(self) -> RobotSpec:
        return self._spec

    def on_sensors(self, reading: SensorReading, heard: list[Heard]) -> Command:
        return self._agent.on_sensors(reading, heard)

    def __getattr__(self, name: str) -> Any:  # on_registered, attach_to, on_chair...: the agent's own
        return getattr(self._agent, name)


def _with_spec(agent: Agent, table: dict[str, Any], where: str) -> Agent:
    own = agent.spec()
    spec = apply_spec(own, table, where=where)
    return agent if spec == own else _WithSpec(agent, spec)
