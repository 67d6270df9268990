"""What every tool that runs a Create m-file program in GNU Octave shares: the executable, how a
path becomes an Octave string, which file names Octave can call, and the lines of Octave's output
that look like errors but are not."""

from __future__ import annotations

from pathlib import Path

OCTAVE = "octave-cli"
#: Octave's lines that start with ``error:`` but are not the error: the call stack's heading, and
#: Octave 7's complaint on exiting from ``--eval``.
OCTAVE_NOISE = ("error: called from", "error: ignoring const execution_exception")
BAD_NAME = "not a MATLAB function's file name (letters, digits, _; e.g. lab1.m)"


def octave_string(text: str) -> str:
    """``text`` as an Octave/MATLAB single-quoted string literal."""
    return "'" + text.replace("'", "''") + "'"


def program_name_problem(path: Path) -> str | None:
    """Why ``path`` cannot be a program Octave calls (None: it can): Octave calls a function file
    by its name, so the name must be one MATLAB can call."""
    name = path.stem
    if path.suffix != ".m" or not (name.isascii() and name.isidentifier()) or len(name) > 63:
        return BAD_NAME
    return None
