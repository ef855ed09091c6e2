"""What ships with the package: the scenarios, the maps they run on and a sample recording.

``maps/`` installs as ``iw_zenoh.data`` (scenarios in its ``scenarios/`` folder, beside the maps
they name by relative path) and ``recordings/demo-sample.mcap`` as ``iw_zenoh.samples``, so an
installed ``iwz`` runs ``iwz run demo`` from any folder, with no checkout. ``iwz scenarios`` lists
them and copies one, with every file it names, to start one's own (docs/scenarios.md).
"""

from __future__ import annotations

import argparse
import re
import shutil
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

from iw_zenoh.errors import ConfigError

__all__ = [
    "ShippedScenario",
    "copy_scenario",
    "data_dir",
    "main",
    "resolve_scenario",
    "sample_recording",
    "scenarios",
]

SAMPLE = "demo-sample.mcap"
_QUOTED_PATH = re.compile(r'"((?:\.\./)+)([A-Za-z0-9_][A-Za-z0-9_./-]*)"')  # "../liacc.xml" in a scenario
_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_-]*")
_SUMMARY_CHARS = 150  # a line of `iwz scenarios` stays readable in a wide terminal


@dataclass(frozen=True, slots=True)
class ShippedScenario:
    """One scenario that ships.

    Attributes:
        name: What ``iwz run NAME`` takes (the file's stem).
        path: The file, as installed.
        summary: The first sentence of the file's opening comment.
    """

    name: str
    path: Path
    summary: str


def data_dir() -> Path:
    """The installed ``maps/`` folder (maps, grids, parameters, chair specs, ``scenarios/``)."""
    return Path(str(resources.files("iw_zenoh.data")))


def sample_recording() -> Path:
    """The installed sample recording (the demo, 31 s)."""
    return Path(str(resources.files("iw_zenoh.samples"))) / SAMPLE


def _summary(text: str) -> str:
    lines = []
    for line in text.splitlines():
        if not line.startswith("#"):
            break
        lines.append(line.lstrip("#").strip())
    comment = " ".join(lines)
    end = re.search(r"\.(\s|$)", comment)
    sentence = comment[: end.start() + 1] if end else comment
    return sentence if len(sentence) <= _SUMMARY_CHARS else sentence[: _SUMMARY_CHARS - 3].rstrip() + "..."


def scenarios() -> list[ShippedScenario]:
    """Every shipped scenario, by name."""
    found = sorted((data_dir() / "scenarios").glob("*.toml"))
    return [ShippedScenario(p.stem, p, _summary(p.read_text(encoding="utf-8"))) for p in found]


def _names() -> str:
    return ", ".join(s.name for s in scenarios())


def resolve_scenario(arg: str) -> Path:
    """The scenario file ``iwz run ARG`` means: ARG itself when it names a file (or has a folder or
    a suffix), else the shipped scenario of that name.

    Raises:
        ConfigError: A bare name that is neither a file here nor a shipped scenario, naming both.
    """
    path = Path(arg)
    if path.exists() or not _NAME.fullmatch(arg):
        return path
    shipped = data_dir() / "scenarios" / f"{arg}.toml"
    if shipped.is_file():
        return shipped
    raise ConfigError(arg, f"no such file, and no shipped scenario of that name (they are: {_names()})")


def copy_scenario(name: str, dest: Path) -> list[Path]:
    """Copies shipped scenario ``name`` into folder ``dest`` with every file it names, their paths
    made relative to the copy, so that ``iwz run DEST/NAME.toml`` runs as the shipped one does.

    Returns:
        The files written, the scenario first.

    Raises:
        ConfigError: An unknown name, or a file that is already there (nothing is overwritten).
    """
    source = data_dir() / "scenarios" / f"{name}.toml"
    if not _NAME.fullmatch(name) or not source.is_file():
        raise ConfigError(name, f"not a shipped scenario (they are: {_names()})")
    text = source.read_text(encoding="utf-8")
    named = sorted({m.group(2) for m in _QUOTED_PATH.finditer(text)})
    for rel in named:  # every file it names lies in the shipped folder, and its copy in dest
        if ".." in Path(rel).parts or not (data_dir() / rel).is_file():
            raise ConfigError(f"{name}: {rel}", "names no shipped file: nothing copied")
    targets = [dest / f"{name}.toml", *(dest / rel for rel in named)]
    taken = [t for t in targets if t.exists()]
    if taken:
        raise ConfigError(str(taken[0]), "already exists: copy into an empty folder, nothing is overwritten")
    for rel, target in zip(named, targets[1:], strict=True):
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(data_dir() / rel, target)
    targets[0].parent.mkdir(parents=True, exist_ok=True)
    targets[0].write_text(_QUOTED_PATH.sub(r'"\2"', text), encoding="utf-8")
    return targets


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="iwz scenarios",
        description="The scenarios that ship with iw-zenoh: list them, or copy one to start your own.",
        epilog=(
            "Examples:\n"
            "  iwz scenarios                      every shipped scenario, one line each\n"
            "  iwz run demo                       run one by its name, from any folder\n"
            "  iwz scenarios copy slalom mine/    slalom.toml and the maps it names, to edit\n"
            "  iwz run mine/slalom.toml           ... and run the copy\n"
            '  iwz view "$(iwz scenarios sample)" the sample recording in the viewer'
        ),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    sub = p.add_subparsers(dest="cmd")
    sub.add_parser("list", help="every shipped scenario, one line each (the default)")
    c = sub.add_parser("copy", help="copy a scenario and every file it names into a folder")
    c.add_argument("name", help="a shipped scenario's name (iwz scenarios lists them)")
    c.add_argument("dest", help="the folder to copy into (made if missing; nothing is overwritten)")
    sub.add_parser("sample", help="print the sample recording's path")
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Runs ``iwz scenarios``."""
    args = _parser().parse_args(argv)
    if args.cmd == "sample":
        print(sample_recording())
        return 0
    if args.cmd == "copy":
        try:
            written = copy_scenario(args.name, Path(args.dest))
        except ConfigError as e:
            print(f"iwz scenarios: {e}", file=sys.stderr)
            return 2
        except OSError as e:
            print(f"iwz scenarios: cannot write into {args.dest}: {e.strerror}", file=sys.stderr)
            return 2
        for path in written:
            print(path)
        print(f"run it: iwz run {written[0]}", file=sys.stderr)
        return 0
    found = scenarios()
    width = max(len(s.name) for s in found)
    for s in found:
        print(f"{s.name:<{width}}  {s.summary}")
    print(f"\nrun one: iwz run NAME; start your own: iwz scenarios copy NAME DIR (from {data_dir()})")
    return 0
