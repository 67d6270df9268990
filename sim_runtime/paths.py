"""Where shipped files live: the source tree when run from a checkout, else the install."""

from __future__ import annotations

import filecmp
import os
from pathlib import Path

PACKAGE_NAME = "robot_sims"
_CHECKOUT = Path(__file__).resolve().parent.parent


def config_dir() -> Path:
    """The ``config/`` folder: the checkout's, or ``share/robot_sims/config`` when installed."""
    if (_CHECKOUT / "package.xml").is_file():
        return _CHECKOUT / "config"
    from ament_index_python.packages import get_package_share_directory

    return Path(get_package_share_directory(PACKAGE_NAME)) / "config"


def config_path(relative: str) -> Path:
    """Absolute path of a shipped file, e.g. ``config_path('create/example.map')``."""
    return config_dir() / relative


def package_share_dir() -> Path | None:
    """``share/robot_sims`` as the ament index finds it (AMENT_PREFIX_PATH), or None (also
    without ROS at all: the URDF and the models work there too)."""
    share = _share_dir(PACKAGE_NAME)
    return share.resolve() if share is not None and share.is_dir() else None


def _share_dir(package: str) -> Path | None:
    try:
        from ament_index_python.packages import PackageNotFoundError, get_package_share_directory
    except ImportError:
        return None
    try:
        return Path(get_package_share_directory(package, print_warning=False))
    except (PackageNotFoundError, OSError, ValueError):
        return None


def mesh_uri(path: str | os.PathLike[str]) -> str:
    """URI of a mesh file for URDFs and markers: ``package://robot_sims/…`` when possible.

    A ``package://`` URI is resolved by whoever loads it (RViz, Foxglove, robot_state_publisher
    users) through their own ament index, so it also works on another machine that has the
    package installed; an absolute ``file://`` URI only works where the file is. So: a file inside
    the installed ``share/robot_sims`` (found through the ament index), or a shipped file of this
    checkout whose identical copy is installed there, gets ``package://robot_sims/<path in
    share>``; anything else (a checkout without an install, a user's own meshes) gets ``file://``.
    """
    path = Path(path).resolve()
    share = package_share_dir()
    if share is not None:
        relative = _relative_to(path, share)
        if relative is None:
            # A checkout's shipped file: its installed copy, if it is the same file.
            in_config = _relative_to(path, config_dir().resolve())
            installed = share / "config" / in_config if in_config is not None else None
            if installed is not None and installed.is_file() and filecmp.cmp(path, installed, shallow=False):
                relative = installed.relative_to(share)
        if relative is not None:
            return f"package://{PACKAGE_NAME}/{relative.as_posix()}"
    return path.as_uri()


def mesh_path(uri: str) -> Path | None:
    """The local file a mesh URI names: ``file://`` (or a bare path), or ``package://<package>/…``
    through the ament index, as RViz resolves it; None where it cannot be resolved here."""
    from urllib.parse import unquote, urlparse

    parsed = urlparse(uri)
    if parsed.scheme in ("file", ""):
        return Path(unquote(parsed.path))
    if parsed.scheme == "package":
        share = _share_dir(parsed.netloc)
        return None if share is None else share / unquote(parsed.path).lstrip("/")
    return None


def _relative_to(path: Path, folder: Path) -> Path | None:
    try:
        return path.relative_to(folder)
    except ValueError:
        return None


def resolve_input_file(value: str, parameter: str) -> Path:
    """Where a file parameter points: an absolute path; else relative to the current directory;
    else relative to the shipped ``config/`` (so ``world_file:=simrobot/demo.yaml`` works from
    anywhere). Not found, or found but not a regular file (a directory, a FIFO, a device), or a
    name the system refuses: :class:`InputError` naming the parameter and every place looked at."""
    from sim_runtime.errors import InputError
    from sim_runtime.inputfile import file_problem, shown

    named = f"parameter '{parameter}' = {shown(repr(value))}"
    try:
        given = Path(value).expanduser()
        places = [given] if given.is_absolute() else [Path.cwd() / given, config_dir() / given]
    except (OSError, RuntimeError) as err:  # no home folder for '~', the current folder deleted
        raise InputError(f"{named}: not a usable file name ({err})") from None
    for place in places:
        problem = file_problem(place)
        if problem is None:
            return place
        if problem != "not found":
            raise InputError(f"{named}: {shown(place)}: {problem}, not a readable file")
    looked = " or ".join(shown(p) for p in places)
    raise InputError(f"{named}: no such file ({looked})")
