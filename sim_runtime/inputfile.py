"""Reading the files users name (maps, configs, worlds, bitmaps, meshes, bags); no ROS imports.

A path from a file or a parameter may be anything: a name too long for the file system, one
holding a NUL, a directory, a FIFO (opening one for reading waits for a writer, forever), a device
such as ``/dev/zero`` (endless) or ``/dev/stdin``. Every loader reads through
:func:`read_input_bytes` / :func:`read_input_text`, which turn each of these into an
:class:`InputError` at once: the file is opened non-blocking, must be a regular file, and is read
up to a size limit.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

from sim_runtime.errors import InputError

#: Largest text input (map, config, YAML): far beyond any hand-written file.
MAX_TEXT_BYTES = 64 * 2**20
#: Largest binary input (STL mesh, bitmap).
MAX_BINARY_BYTES = 2**30

_KINDS = (
    (stat.S_ISDIR, "a directory"),
    (stat.S_ISFIFO, "a FIFO (named pipe)"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISSOCK, "a socket"),
)
_SHOWN_CHARS = 120  # of a path in a message: a fuzzed name can be thousands of characters


def shown(path: str | os.PathLike[str]) -> str:
    """``path`` for a message, its middle cut out when it is very long."""
    text = os.fspath(path).replace("\0", "\\0")
    if len(text) <= _SHOWN_CHARS:
        return text
    half = _SHOWN_CHARS // 2
    return f"{text[:half]}…({len(text)} characters)…{text[-half:]}"


def _reason(error: OSError | ValueError) -> str:
    if isinstance(error, ValueError):  # os functions refuse a name holding a NUL this way
        return "the name holds a NUL character"
    return error.strerror or type(error).__name__


def _kind(mode: int) -> str:
    return next((name for test, name in _KINDS if test(mode)), "not a regular file")


def file_problem(path: str | os.PathLike[str]) -> str | None:
    """Why ``path`` cannot be read as an input file ("not found", "a FIFO (named pipe)", "File name
    too long", …), or None when it is a regular file. Never raises, never blocks."""
    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        return "not found"
    except (OSError, ValueError) as error:
        return _reason(error)
    return None if stat.S_ISREG(mode) else _kind(mode)


def resolved(path: str | os.PathLike[str]) -> Path:
    """``path`` made absolute with links resolved where possible; never raises (a name holding a
    NUL, a link loop, a name too long stay as given, for the reader to report)."""
    try:
        target = Path(path).resolve()
    except (OSError, ValueError, RuntimeError):
        return Path(os.path.abspath(path))
    if not os.path.exists(target) and os.path.exists(path):  # never raises (a name too long: False)
        # /dev/stdin on a pipe resolves to "/proc/<pid>/fd/pipe:[…]", which names nothing: keep the
        # name the user gave, so the reader says what it is (a FIFO) instead of "not found"
        return Path(os.path.abspath(path))
    return target


def is_regular_file(path: str | os.PathLike[str]) -> bool:
    """Whether ``path`` is a regular file (following links); False for any name the system refuses."""
    return file_problem(path) is None


def read_input_bytes(path: str | os.PathLike[str], what: str, limit: int = MAX_BINARY_BYTES) -> bytes:
    """The bytes of the regular file ``path`` (a ``what``, e.g. "STL file", for messages).

    A missing file, a name the system refuses, anything but a regular file, and a file beyond
    ``limit`` bytes raise :class:`InputError` naming the file.
    """
    try:
        # Non-blocking: opening a FIFO then returns at once instead of waiting for a writer.
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_CLOEXEC)
    except FileNotFoundError:
        raise InputError(f"{shown(path)}: {what} not found") from None
    except (OSError, ValueError) as error:
        raise InputError(f"{shown(path)}: cannot open {what}: {_reason(error)}") from None
    info = os.fstat(fd)
    if not stat.S_ISREG(info.st_mode) or info.st_size > limit:
        os.close(fd)
        if not stat.S_ISREG(info.st_mode):
            raise InputError(f"{shown(path)}: {what} is {_kind(info.st_mode)}, not a regular file")
        raise InputError(f"{shown(path)}: {what} is {info.st_size} bytes, more than the limit {limit}")
    with os.fdopen(fd, "rb") as stream:
        try:
            data = stream.read(limit + 1)  # the size may have grown (or lied, as /proc's do)
        except OSError as error:
            raise InputError(f"{shown(path)}: cannot read {what}: {_reason(error)}") from None
    if len(data) > limit:
        raise InputError(f"{shown(path)}: {what} is more than the limit {limit} bytes")
    return data


def read_input_text(
    path: str | os.PathLike[str], what: str, limit: int = MAX_TEXT_BYTES, errors: str = "strict"
) -> str:
    """The UTF-8 text of the regular file ``path``, as :func:`read_input_bytes` reads it; with
    ``errors="strict"`` a file that is not UTF-8 is an :class:`InputError` naming the byte."""
    data = read_input_bytes(path, what, limit)
    try:  # "utf-8-sig": a byte-order mark (Windows editors write one) is not part of the text
        return data.decode("utf-8-sig", errors=errors)
    except UnicodeDecodeError as error:
        raise InputError(
            f"{shown(path)}: {what} is not UTF-8 text (byte {error.start}): is it the right file?"
        ) from None
