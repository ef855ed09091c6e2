"""The options of ``iwz sensors``, ``iwz radio``, ``iwz record`` and ``iwz bridge ciberrato``
(msgspec Structs), and the flags that fill the first three (the bridge's are its own:
``bridges/ciberrato/options.py``).

Apart from the processes themselves (as :mod:`iw_zenoh.nodes.world_options` is for the world) so
that ``iwz run`` builds each role's options from a scenario without importing the role's loop
(the sensors' kernels, the recorder's writer), and with no numpy: a restarted recorder listens
as soon as it can. Each role reads them with :func:`iw_zenoh.process.options.options_from_args`, from
its flags or whole from ``--options JSON``.
"""

from __future__ import annotations

import argparse
from typing import Annotated, Any, Literal

import msgspec

from iw_zenoh.process.options import Flag, add_option_flags

__all__ = [
    "BridgeOptions",
    "RadioOptions",
    "RecorderOptions",
    "SensorsOptions",
    "add_radio_arguments",
    "add_recorder_arguments",
    "add_sensors_arguments",
    "parse_shard",
]

_Count = Annotated[int, msgspec.Meta(ge=1)]


class SensorsOptions(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """How ``iwz sensors`` runs: filled by its flags, or whole by ``--options JSON`` (``iwz run``).

    Attributes:
        shard: ``(K, N)``: compute the robots whose id is K modulo N (1 <= K <= N; ``(1, 1)``: all).
        ahead: Compute a tick ahead from the world's proposal (false: the same readings, later).
        early: Publish those as soon as the collision verdict confirms the proposal, before the
            world's state (false: when the state comes; the same readings, later).
    """

    shard: tuple[_Count, _Count] = (1, 1)
    ahead: bool = True
    early: bool = True

    def __post_init__(self) -> None:
        if self.shard[0] > self.shard[1]:
            raise ValueError(f"shard {self.shard[0]}/{self.shard[1]}: K must not exceed N")

    @property
    def process_name(self) -> str:
        """The shard's instance name, ``sensors-K-N`` (its liveliness token)."""
        return "sensors-{}-{}".format(*self.shard)


class RadioOptions(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """How ``iwz radio`` runs: filled by its flags, or whole by ``--options JSON`` (``iwz run``).

    Attributes:
        range_m: Delivery range, metres.
        max_message_bytes: Longest message, bytes; longer ones are dropped.
        max_heard_bytes: Bytes a robot hears per tick at most.
        early: Deliver a tick as soon as the collision verdict confirms the world's proposal
            (false: when the world's state comes; the same messages, later).
    """

    range_m: Annotated[float, msgspec.Meta(gt=0)] = 8.0  # RadioConfig's defaults (a test sees they agree)
    max_message_bytes: Annotated[int, msgspec.Meta(gt=0)] = 100
    max_heard_bytes: Annotated[int, msgspec.Meta(gt=0)] = 400
    early: bool = True


class BridgeOptions(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """How ``iwz bridge ciberrato`` runs: filled by its flags, or whole by ``--options JSON`` (``iwz run``).

    Attributes:
        port: The UDP registration port (6000: unmodified clients use it).
        bind: The address to listen on (loopback only by default; 0.0.0.0 to open it).
        param: A Ciber-Rato parameters file, what clients are told: sensors on/off, noise ("": the defaults).
        scoring: The legacy ``--scoring``: 0 competitive, 1 control (C1), 2 mapping, 3 planning (C2-C5).
        pace: ``auto``: real-time worlds send every Measures of a cycle at a steady offset from the
            cycle's start; ``off``: each as soon as its readings arrive.
    """

    port: Annotated[int, msgspec.Meta(ge=0, le=65535)] = 6000
    bind: Annotated[str, msgspec.Meta(min_length=1)] = "127.0.0.1"
    param: str = ""
    scoring: Literal[0, 1, 2, 3] = 0
    pace: Literal["auto", "off"] = "auto"


class RecorderOptions(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """How ``iwz record`` runs: filled by its flags, or whole by ``--options JSON`` (``iwz run``).

    Attributes:
        output: The MCAP file to write ("": ``recordings/SIM-DATE-TIME.mcap``).
        meta: Metadata to store (``iw.user``), e.g. ``{"scenario": "demo"}``.
        quiet: No progress lines.
        continue_run: None: write ``output`` afresh; else, when ``output`` already holds a
            recording (of this run id, if not ""), write its next part (how a restarted
            recorder goes on).
    """

    output: str = ""
    meta: dict[Annotated[str, msgspec.Meta(min_length=1)], str] = msgspec.field(default_factory=dict)
    quiet: bool = False
    continue_run: str | None = None


def parse_shard(text: str) -> tuple[int, int]:
    """Parses ``K/N`` (1 <= K <= N).

    Raises:
        ValueError: Saying what a shard looks like.
    """
    k, sep, n = text.partition("/")
    try:
        kk, nn = int(k), int(n)
    except ValueError:
        kk = nn = 0
    if not sep or nn < 1 or not 1 <= kk <= nn:
        raise ValueError(f"--shard takes K/N with 1 <= K <= N (e.g. 2/3), got {text!r}")
    return kk, nn


def _shard_flag(text: str) -> tuple[int, int]:
    try:
        return parse_shard(text)
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e)) from None


class _MetaItem(argparse.Action):
    """``--meta KEY=VALUE`` (repeatable) into one dictionary."""

    def __call__(
        self, parser: argparse.ArgumentParser, ns: argparse.Namespace, value: Any, flag: str | None = None
    ) -> None:
        k, sep, v = str(value).partition("=")
        if not sep or not k:
            raise argparse.ArgumentError(self, f"takes KEY=VALUE, got {value!r}")
        setattr(ns, self.dest, {**getattr(ns, self.dest, {}), k: v})


_SENSORS: tuple[Flag, ...] = (
    (
        "--shard",
        "shard",
        {"type": _shard_flag, "metavar": "K/N"},
        "compute the robots whose id is K modulo N (default 1/1, all)",
    ),
    (
        "--no-ahead",
        "ahead",
        {"action": "store_const", "const": False},
        "do not compute a tick ahead from the world's proposal (the same readings, later; "
        "to compare, or on a machine with one core)",
    ),
    (
        "--no-early",
        "early",
        {"action": "store_const", "const": False},
        "do not publish the readings computed ahead as soon as the collision verdict confirms the "
        "proposal, wait for the world's state (the same readings, later; to compare)",
    ),
)

_RADIO: tuple[Flag, ...] = (
    ("--range", "range_m", {"type": float, "metavar": "M"}, "delivery range in metres (default {default:g})"),
    (
        "--max-bytes",
        "max_message_bytes",
        {"type": int, "metavar": "N"},
        "longest message in bytes; longer ones are dropped (default {default})",
    ),
    (
        "--budget",
        "max_heard_bytes",
        {"type": int, "metavar": "N"},
        "bytes a robot hears per tick at most (default {default})",
    ),
    (
        "--no-early",
        "early",
        {"action": "store_const", "const": False},
        "do not deliver a tick as soon as the collision verdict confirms the world's proposal, "
        "wait for the world's state (the same messages, later; to compare)",
    ),
)

_RECORDER: tuple[Flag, ...] = (
    ("-o --output", "output", {"metavar": "FILE"}, "MCAP file to write (default recordings/SIM-DATE-TIME.mcap)"),
    (
        "--meta",
        "meta",
        {"action": _MetaItem, "metavar": "KEY=VALUE"},
        "metadata to store (repeatable), e.g. scenario=demo",
    ),
    ("--quiet", "quiet", {"action": "store_true"}, "no progress lines"),
    (
        "--continue",
        "continue_run",
        {"nargs": "?", "const": "", "metavar": "RUN"},
        "when FILE already holds a recording (of run id RUN, if given), write its next part "
        "(FILE.part2.mcap...) instead of overwriting it: how a restarted recorder goes on",
    ),
)


def add_sensors_arguments(p: argparse.ArgumentParser) -> None:
    """Adds the flags of ``iwz sensors``, each filling a field of :class:`SensorsOptions`, and ``--options``."""
    add_option_flags(p, SensorsOptions, _SENSORS)


def add_radio_arguments(p: argparse.ArgumentParser) -> None:
    """Adds the flags of ``iwz radio``, each filling a field of :class:`RadioOptions`, and ``--options``."""
    add_option_flags(p, RadioOptions, _RADIO)


def add_recorder_arguments(p: argparse.ArgumentParser) -> None:
    """Adds the flags of ``iwz record``, each filling a field of :class:`RecorderOptions`, and ``--options``."""
    add_option_flags(p, RecorderOptions, _RECORDER)
