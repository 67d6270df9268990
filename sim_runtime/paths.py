"""Where shipped files live: the source tree when run from a checkout, else the install."""

from __future__ import annotations

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


def kernels_cached(module: str) -> bool:
    """Whether numba's on-disk cache holds kernels of ``module`` (e.g. ``create_sim.geometry``).

    numba writes one ``<file>.<function>-<line>.py<ver>.nbi`` index per cached kernel beside the
    source (``__pycache__``) or under ``NUMBA_CACHE_DIR``."""
    import importlib.util
    import os

    spec = importlib.util.find_spec(module)
    if spec is None or spec.origin is None:
        return False
    source = Path(spec.origin)
    folders = [source.parent / "__pycache__"]
    if os.environ.get("NUMBA_CACHE_DIR"):
        cache_root = Path(os.environ["NUMBA_CACHE_DIR"])
        folders.append(cache_root / source.parent.relative_to(source.anchor))
    return any(any(folder.glob(f"{source.stem}.*.nbi")) for folder in folders if folder.is_dir())


def resolve_input_file(value: str, parameter: str) -> Path:
    """Where a file parameter points: an absolute path; else relative to the current directory;
    else relative to the shipped ``config/`` (so ``world_file:=simrobot/demo.yaml`` works from
    anywhere). Not found: :class:`InputError` naming the parameter and every place looked at."""
    from sim_runtime.errors import InputError

    given = Path(value).expanduser()
    places = [given] if given.is_absolute() else [Path.cwd() / given, config_dir() / given]
    for place in places:
        if place.is_file():
            return place
    looked = " or ".join(str(p) for p in places)
    raise InputError(f"parameter '{parameter}' = {value!r}: no such file ({looked})")
