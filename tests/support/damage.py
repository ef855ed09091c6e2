"""Damaged copies of a real recording, seeded: flipped bits, truncations, zeroed ranges, swapped
chunks (shared by tests/record/test_damaged_corpus.py and benchmarks/damaged_recordings.py)."""

from __future__ import annotations

import contextlib
import io
import random
import re
import traceback
from collections import Counter
from collections.abc import Callable
from pathlib import Path

from mcap.reader import make_reader

from iw_zenoh.record.reader import open_recording
from iw_zenoh.record.recording import Recorder

__all__ = ["KINDS", "damaged", "judge", "messages", "small_recording"]

SAMPLE = Path(__file__).resolve().parents[2] / "recordings" / "demo-sample.mcap"
KINDS = ("flip", "truncate", "zero", "swap")

Messages = Counter[tuple[str, int, int, bytes]]


def small_recording(n: int = 600, chunk_size: int = 6000) -> bytes:
    """The sample's first ``n`` messages recorded afresh (real keys and payloads), in small chunks."""
    buf = io.BytesIO()
    rec = Recorder(buf, {"iw.scenario": {"name": "damaged-corpus"}}, chunk_size=chunk_size, scene=False)
    with SAMPLE.open("rb") as f:
        for i, (_, ch, m) in enumerate(make_reader(f).iter_messages()):
            if i >= n:
                break
            if ch.topic.startswith("iw/"):
                rec.add(ch.topic, m.data, m.log_time)
    rec.finish()
    return buf.getvalue()


def _chunks(data: bytes) -> list[tuple[int, int]]:
    summary = make_reader(io.BytesIO(data)).get_summary()
    assert summary is not None
    return [(c.chunk_start_offset, c.chunk_start_offset + c.chunk_length) for c in summary.chunk_indexes]


def damaged(data: bytes, kind: str, seed: int) -> bytes:
    """One damaged copy of ``data`` (a whole recording)."""
    r = random.Random(seed)
    out = bytearray(data)
    if kind == "flip":
        for _ in range(r.randint(1, 8)):
            out[r.randrange(8, len(out) - 8)] ^= 1 << r.randrange(8)
    elif kind == "truncate":
        del out[r.randrange(9, len(out) - 1) :]
    elif kind == "zero":
        at, n = r.randrange(8, len(out) - 8), r.randint(4, 4096)
        out[at : at + n] = bytes(len(out[at : at + n]))
    elif kind == "swap":
        (a0, a1), (b0, b1) = sorted(r.sample(_chunks(data), 2))
        out = bytearray(data[:a0] + data[b0:b1] + data[a1:b0] + data[a0:a1] + data[b1:])
    else:
        raise ValueError(kind)
    return bytes(out)


def messages(path: Path) -> Messages:
    """Every message of a recording as (topic, log time, publish time, payload), counted."""
    with open_recording(path) as rec:
        return Counter((r.topic, r.log_time, r.publish_time, r.data) for r in rec.raw())


def _run(main: Callable[[list[str]], int], argv: list[str]) -> tuple[int, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            rc = main(argv)
        except SystemExit as e:
            rc = e.code if isinstance(e.code, int) else 2
        except Exception:
            return -1, traceback.format_exc()
    return rc, out.getvalue() + err.getvalue()


def _readers(path: Path, tmp: Path) -> dict[str, list[str]]:
    s = str(path)
    return {
        "doctor": [s],
        "incidents": [s],
        "report": [s],
        "render": [s, "--at", "1", "-o", str(tmp / "at1.png")],
        "resim": [s],
    }


def judge(original: Path, data: bytes, tmp: Path, *, readers: bool = True) -> list[str]:
    """What a damaged copy's handling gets wrong (see the corpus test's doc): empty when nothing."""
    from iw_zenoh.record import incidents, render, report, resim
    from iw_zenoh.record.tools import check, doctor_main, recover_main

    mains = {"doctor": doctor_main, "incidents": incidents.main, "report": report.main, "render": render.main}
    mains["resim"] = resim.main
    bad = tmp / "damaged.mcap"
    bad.write_bytes(data)
    wrong: list[str] = []
    want = messages(original)
    if check(bad).whole and messages(bad) != want:
        wrong.append("doctor calls the damaged file whole, yet its messages differ")
    fixed = tmp / "fixed.mcap"
    fixed.unlink(missing_ok=True)
    rc, said = _run(recover_main, [str(bad), "-o", str(fixed)])
    if rc == 0 and check(fixed).whole:
        got = messages(fixed)
        if got - want:
            wrong.append(f"recover made a whole file with {sum((got - want).values())} messages not recorded")
        elif got != want and not re.search(r"dropped whole|reading stopped: (?!the file was complete)", said):
            wrong.append("recover lost messages without a word")
    wrong += _says_in_words("recover", rc, said)
    if readers and not check(bad).whole:
        for name, argv in _readers(bad, tmp).items():
            rc, said = _run(mains[name], argv)
            if rc == 0 and "note:" not in said:
                wrong.append(f"{name} read a damaged file with exit 0 and no word")
            wrong += _says_in_words(name, rc, said)
    return wrong


_EXCEPTION = re.compile(r"\b(Traceback|[A-Z][A-Za-z]*(Error|Exception)|EndOfFile|InvalidMagic)\b")


def _says_in_words(name: str, rc: int, said: str) -> list[str]:
    if rc == -1:
        return [f"{name} raised: {said.strip().splitlines()[-1]}"]
    if m := _EXCEPTION.search(said):
        return [f"{name} names an exception ({m[0]}): {said.strip()[:200]}"]
    return []
