"""One process that ``iwz run`` starts and supervises: its command line, log, start, stop."""

from __future__ import annotations

import logging
import signal
import subprocess
import time
from dataclasses import dataclass
from pathlib import Path

import msgspec

from iw_zenoh.nodes.world_seal import SEAL_ENV

__all__ = ["RECORDER_STOP_S", "Child", "stop_in_order"]

logger = logging.getLogger(__name__)

STOP_ORDER = {"agent": 0, "world": 2, "record": 3, "router": 4}  # by role; the rest 1
# a stopped recorder writes what is still in flight (up to recorder.DRAIN_MAX_S, 30 s: a lock-step
# run's backlog on a loaded machine) and then finishes the file; killed before, the file is cut off
RECORDER_STOP_S = 45.0


@dataclass
class Child:
    """One supervised process."""

    role: str
    name: str
    argv: list[str]
    log: Path
    proc: subprocess.Popen[bytes] | None = None
    restarts: int = 0
    expected_exit: bool = False
    cwd: Path | None = None
    token: str = ""  # the name of its liveliness token ("": any of its role's)
    options: msgspec.Struct | None = None  # its typed options, in its command line as --options JSON
    seen: bool = False  # its liveliness token was seen at least once: it started

    def owns_token(self, role: str, name: str) -> bool:
        """Whether the liveliness token ``role``/``name`` is this child's."""
        return self.token_role == role and self.token in ("", name)

    @property
    def token_role(self) -> str:
        """The role its liveliness token names (the bridge drives robots: an agent)."""
        return {"record": "recorder", "bridge": "agent"}.get(self.role, self.role)

    def start(self, env: dict[str, str]) -> None:
        """Starts (or restarts) the process, its output to its log file (the world's key for
        sealing its descriptions, :mod:`iw_zenoh.nodes.world_seal`, to the world only)."""
        if self.role != "world":
            env = {k: v for k, v in env.items() if k != SEAL_ENV}
        with self.log.open("ab") as f:
            self.proc = subprocess.Popen(
                self.argv,
                stdout=f,
                stderr=subprocess.STDOUT,
                stdin=subprocess.DEVNULL,
                env=env,
                start_new_session=True,
                cwd=self.cwd,
            )

    def set_option(self, flag: str, value: str) -> None:
        """Replaces the value after ``flag`` in its command line (for its next start)."""
        at = self.argv.index(flag)
        self.argv[at + 1] = value

    def alive(self) -> bool:
        """Whether it is running."""
        return self.proc is not None and self.proc.poll() is None

    def stop(self) -> None:
        """Asks it to stop (SIGTERM)."""
        self.expected_exit = True
        if self.alive():
            assert self.proc is not None
            self.proc.send_signal(signal.SIGTERM)

    def tail(self, lines: int = 8) -> str:
        """The last lines of its log."""
        try:
            return "\n".join(self.log.read_text(errors="replace").splitlines()[-lines:])
        except OSError:
            return ""

    def error(self, lines: int = 12) -> str:
        """What it said as it ended: its log from the last line that starts an error (``iwz ...:``,
        a traceback) to the end, or its last lines."""
        try:
            said = self.log.read_text(errors="replace").splitlines()
        except OSError:
            return ""
        starts = [i for i, line in enumerate(said) if line.startswith(("iwz ", "Traceback"))]
        return "\n".join(said[starts[-1] :][:lines] if starts else said[-lines:])


def stop_in_order(children: list[Child], timeout_s: float = 8.0) -> None:
    """Stops children group by group: agents first, then the roles beside the world, the world,
    the recorder, the router last; each group is waited for, SIGKILLed after ``timeout_s`` (the
    recorder after :data:`RECORDER_STOP_S` at least: it finishes its file)."""
    for group in sorted(set(STOP_ORDER.values()) | {1}):
        members = [c for c in children if STOP_ORDER.get(c.role, 1) == group]
        for c in members:
            c.stop()
        wait_s = max(timeout_s, RECORDER_STOP_S) if any(c.role == "record" for c in members) else timeout_s
        deadline = time.monotonic() + wait_s
        for c in members:
            if c.proc is None:
                continue
            try:
                c.proc.wait(max(0.1, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                logger.warning("%s did not stop: killing it", c.name)
                c.proc.kill()
                c.proc.wait(5)
