"""The one folder the studio reads and writes: every path from the browser is resolved inside it."""

from __future__ import annotations

import os
from pathlib import Path

from sim_runtime.errors import InputError
from sim_runtime.inputfile import file_problem, read_input_text

MAX_UPLOAD_BYTES = 1_000_000
"""Map and config files are a few kB; anything larger is refused before it is read."""


def upload_text(name: str, data: bytes, kind: str) -> str:
    """An uploaded file's text; InputError naming the file when it is too large or not text."""
    if len(data) > MAX_UPLOAD_BYTES:
        raise InputError.at(name, None, f"{kind} file is {len(data)} bytes, more than the limit {MAX_UPLOAD_BYTES}")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as err:
        raise InputError.at(
            name, None, f"not a text file (byte {err.start} is not UTF-8): a {kind} file is text"
        ) from None
    if "\x00" in text:
        raise InputError.at(name, None, f"not a text file (it holds NUL bytes): a {kind} file is text")
    return text


class Workspace:
    """Files under ``root`` only: absolute paths, ``..`` and symlinks that lead outside are refused."""

    def __init__(self, root: str | Path) -> None:
        self.root = Path(root).resolve()
        if not self.root.is_dir():
            raise InputError(f"workspace {str(root)!r} is not a folder")

    def path(self, name: str) -> Path:
        """The file ``name`` (relative to the workspace) as an absolute path inside it."""
        name = name.strip()
        if not name:
            raise InputError("no file name given")
        if "\x00" in name:
            raise InputError(f"file name {name!r} contains a NUL character")
        candidate = Path(name)
        if candidate.is_absolute():
            raise InputError(f"{name!r}: give a path relative to the workspace {self.root}")
        resolved = (self.root / candidate).resolve()
        if resolved != self.root and self.root not in resolved.parents:
            raise InputError(f"{name!r} is outside the workspace {self.root}")
        return resolved

    def relative(self, path: Path) -> str:
        """``path`` (inside the workspace) as the name the browser shows."""
        return str(Path(path).resolve().relative_to(self.root))

    def read_text(self, name: str, kind: str) -> tuple[str, Path]:
        """A text file's contents and path; InputError if missing, too large or outside."""
        path = self.path(name)
        if file_problem(path) == "not found":
            raise InputError.at(name, None, f"{kind} file not found in the workspace {self.root}")
        # A FIFO, a folder or a name too long: refused by the reader, at once.
        return read_input_text(path, f"{kind} file", MAX_UPLOAD_BYTES, errors="replace"), path

    def write_text(self, name: str, text: str, *, overwrite: bool = False) -> Path:
        """Write ``text`` to ``name`` (parent folders made); an existing file only if ``overwrite``."""
        path = self.path(name)
        if path.exists() and not overwrite:
            raise InputError.at(name, None, "file exists (tick 'overwrite' to replace it)")
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
        tmp.write_text(text, encoding="utf-8")
        tmp.replace(path)  # readers never see a half-written file
        return path

    def files(self, suffixes: tuple[str, ...]) -> list[str]:
        """Workspace files with one of ``suffixes`` (a few levels deep), for the file pickers: a
        link is listed under its own name only if it leads to a file inside the workspace (a link
        out of it, or to nothing, is left out: opening it would be refused)."""
        found = []
        for dirpath, dirnames, filenames in os.walk(self.root):  # links to folders are not entered
            folder = Path(dirpath)
            depth = len(folder.relative_to(self.root).parts)
            dirnames[:] = sorted(d for d in dirnames if not d.startswith(".") and depth < 3)
            found += [
                (folder / f).relative_to(self.root).as_posix()
                for f in sorted(filenames)
                if f.endswith(suffixes) and not f.startswith(".") and self.inside(folder / f)
            ]
            if len(found) > 500:
                break
        return found

    def inside(self, path: Path) -> bool:
        """Whether ``path`` is, or links to, an existing file in the workspace."""
        try:
            target = path.resolve(strict=True)
        except (OSError, RuntimeError):  # dangling, a loop of links, unreadable
            return False
        return self.root in target.parents and target.is_file()

    def new_folder_name(self, stem: str) -> str:
        """``stem_1``, ``stem_2``, … : the first name not taken (the original's SimulatorOutputData_* rule)."""
        n = 1
        while self.path(f"{stem}_{n}").exists():
            n += 1
        return f"{stem}_{n}"
