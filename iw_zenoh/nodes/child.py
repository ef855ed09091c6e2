"""One process that ``iwz run`` starts and supervises: its command line, log, start, stop."""

from __future__ import annotations

import signal
import subprocess
from dataclasses import dataclass
from pathlib import Path

import msgspec

__all__ = ["Child"]


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
        """Starts (or restarts) the process, its output to its log file."""
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
