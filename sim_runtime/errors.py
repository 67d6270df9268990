"""Errors for bad user input (files, parameters, commands); no ROS imports."""

from __future__ import annotations

from os import PathLike


class InputError(ValueError):
    """A user-supplied file, parameter or command is invalid.

    The message always names where the bad value came from (file and line, parameter or
    field) and the value itself, so the user can fix it without reading our code.
    """

    @classmethod
    def at(cls, path: str | PathLike[str], line: int | None, message: str) -> InputError:
        """Build an error located at ``path:line`` (``line`` None for whole-file problems)."""
        where = f"{path}:{line}" if line is not None else f"{path}"
        return cls(f"{where}: {message}")
