"""Run Rerun's CLI and viewer without usage analytics or telemetry leaving this machine.

Rerun's CLI and viewer send anonymous usage analytics unless ``rerun analytics disable`` was run
for the user's config home. Tests and make targets must not send anything, so they run every
Rerun CLI/viewer call with :func:`private_rerun_env`: a config home in a private folder where
analytics were disabled first.

Users opt out once for their own account with ``rerun analytics disable``.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

# FORCE_RERUN_ANALYTICS turns analytics on whatever the config says: never pass it through.
_DROP = ("FORCE_RERUN_ANALYTICS",)


def rerun_cli() -> str:
    """Path of the ``rerun`` executable next to this Python (the venv's), else on PATH."""
    beside = Path(sys.executable).with_name("rerun")
    if beside.is_file():
        return str(beside)
    found = shutil.which("rerun")
    if found is None:
        raise FileNotFoundError("the rerun CLI is not installed (pip install rerun-sdk)")
    return found


def private_rerun_env(folder: str | os.PathLike, base: dict[str, str] | None = None) -> dict[str, str]:
    """Environment for Rerun CLI/viewer calls with a private config home where analytics are off.

    Creates ``folder`` (HOME, XDG_CONFIG_HOME, XDG_DATA_HOME, XDG_CACHE_HOME inside it), runs
    ``rerun analytics disable`` there once, and returns ``base`` (default ``os.environ``) with those
    variables set and OpenTelemetry export switched off.
    """
    home = Path(folder).resolve()
    env = {k: v for k, v in (os.environ if base is None else base).items() if k not in _DROP}
    env.update(
        {
            "HOME": str(home),
            "XDG_CONFIG_HOME": str(home / ".config"),
            "XDG_DATA_HOME": str(home / ".local" / "share"),
            "XDG_CACHE_HOME": str(home / ".cache"),
            "TELEMETRY_ENABLED": "false",
        }
    )
    for key in ("XDG_CONFIG_HOME", "XDG_DATA_HOME", "XDG_CACHE_HOME"):
        Path(env[key]).mkdir(parents=True, exist_ok=True)
    config = home / ".config" / "rerun" / "analytics.json"
    if not _disabled_in(config):
        subprocess.run(
            [rerun_cli(), "analytics", "disable"],
            env=env,
            check=True,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            timeout=60,
        )
    return env


def _disabled_in(config: Path) -> bool:
    try:
        return json.loads(config.read_text()).get("analytics_enabled") is False
    except (OSError, ValueError):
        return False


def analytics_disabled(env: dict[str, str]) -> bool:
    """True if ``rerun analytics config`` run with ``env`` reports analytics disabled."""
    out = subprocess.run(
        [rerun_cli(), "analytics", "config"], env=env, check=True, capture_output=True, text=True, timeout=60
    ).stdout
    return json.loads(out).get("analytics_enabled") is False


def main(args: list[str] | None = None) -> int:
    """``python -m sim_tools.rerun_view.analytics RERUN_ARGS…``: run the rerun CLI (or viewer)
    with a fresh private config home where analytics are disabled; for make targets and CI."""
    argv = sys.argv[1:] if args is None else list(args)
    with tempfile.TemporaryDirectory(prefix="rerun_home_") as home:
        return subprocess.run([rerun_cli(), *argv], env=private_rerun_env(home), check=False).returncode


if __name__ == "__main__":
    sys.exit(main())
