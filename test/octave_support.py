"""GNU Octave as a user runs it, for the MATLAB tests and bench/matlab_roundtrip.py: ``octave-cli
--eval`` on a script, or octave-cli at its interactive prompt on a pseudo-terminal, where a Ctrl-C
typed is a SIGINT from Octave's own terminal."""

from __future__ import annotations

import fcntl
import os
import pty
import re
import select
import shutil
import subprocess
import termios
import threading
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
OCTAVE = shutil.which("octave-cli")
# A killed Octave would otherwise leave an octave-workspace file in its working directory.
NO_CORE = "crash_dumps_octave_core(false); sigterm_dumps_octave_core(false); sighup_dumps_octave_core(false); "
TERMINAL_CODES = re.compile(r"\x1b\[[0-9;?]*[A-Za-z]")  # the prompt's cursor moves and modes


def octave_command(script: str) -> list[str]:
    """The command line of ``octave-cli --eval script``, with no core file should it be killed."""
    return [OCTAVE or "octave-cli", "--no-gui", "--quiet", "--eval", f"{NO_CORE}{script}"]


def octave_eval(script: str, env: dict[str, str], **popen: Any) -> subprocess.Popen:
    """``octave-cli --eval script`` in ROOT (unless ``cwd`` says otherwise), started, not waited for."""
    popen.setdefault("cwd", ROOT)
    return subprocess.Popen(octave_command(script), env=env, **popen)


class OctavePrompt:
    """octave-cli at its interactive prompt on a pseudo-terminal, as a user types into it; ``setup``
    is typed first and must print ``READY`` (within ``ready_within`` s: a cold start is slow)."""

    def __init__(self, setup: str, env: dict[str, str], ready_within: float = 60.0) -> None:
        master, slave = pty.openpty()

        def own_terminal() -> None:  # Octave's session leader and controlling terminal: ^C reaches it
            os.setsid()
            fcntl.ioctl(0, termios.TIOCSCTTY, 0)

        self.process = subprocess.Popen(
            [OCTAVE or "octave-cli", "--no-gui", "--quiet", "--no-history", "--no-init-file"],
            stdin=slave,
            stdout=slave,
            stderr=slave,
            env=env,
            cwd=ROOT,
            preexec_fn=own_terminal,
        )
        os.close(slave)
        self.master = master
        self.output = ""
        self._mark = 0
        self._lock = threading.Lock()
        threading.Thread(target=self._read, daemon=True).start()
        self.type(f"{NO_CORE}{setup}")
        self.expect(r"^READY", timeout=ready_within)

    def _read(self) -> None:
        while True:
            ready, _, _ = select.select([self.master], [], [], 0.1)
            if ready:
                try:
                    chunk = os.read(self.master, 65536).decode(errors="replace")
                except OSError:  # the terminal closed
                    return
                with self._lock:
                    self.output += chunk

    def type(self, line: str) -> None:
        """Type ``line`` and Enter; :meth:`expect` then looks at what is printed from here on."""
        with self._lock:
            self._mark = len(self.output)
        os.write(self.master, line.encode() + b"\n")

    def ctrl_c(self) -> None:
        os.write(self.master, b"\x03")

    def expect(self, pattern: str, timeout: float = 30) -> re.Match[str]:
        """The first line matching ``pattern`` printed since the last line typed."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            with self._lock:
                text = TERMINAL_CODES.sub("", self.output[self._mark :]).replace("\r", "")
            match = re.search(pattern, text, re.MULTILINE)
            if match:
                return match
            time.sleep(0.02)
        raise AssertionError(f"Octave never printed {pattern!r}; it printed:\n{self.output[-2000:]}")

    def close(self) -> None:
        self.type("exit")
        try:
            self.process.wait(timeout=20)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()
        os.close(self.master)
