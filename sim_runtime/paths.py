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
