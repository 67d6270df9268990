"""The studio in JupyterLab: jupyter-server-proxy's entry for ``robot_sims studio``.

Installed with ``pip install robot_sims[jupyter]``, setup.py registers :func:`setup_studio` under
the ``jupyter_serverproxy_servers`` entry point: every user's JupyterLab launcher then shows
"robot_sims studio", which jupyter-server-proxy starts on first use under the user's own prefix
(``<base_url>robot_sims/``: ``/user/<name>/robot_sims/`` in a JupyterHub). The studio listens on a
Unix socket in a private temporary folder (0700, the socket 0600), so no other user reaches it
through ``/proxy/<port>/`` or a terminal's ``curl``: every request passes the Jupyter server's own
authentication. It ends with the Jupyter server, however that ends (``--exit-with-parent``).

This module is loaded by every Jupyter server at start: it imports neither NiceGUI nor rclpy.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path
from typing import Any

NAME = "robot_sims"
"""The entry point's name, hence the path under the Jupyter server (``<base_url>robot_sims/``)."""
START_TIMEOUT = 120.0
"""Seconds the proxy waits for the studio's first answer: three studios starting at once took
5.3-5.8 s (jupyter-server-proxy's default is 5 s), and a busy machine takes longer."""


def workspace() -> Path:
    """The studio's workspace: ``$ROBOT_SIMS_WORKSPACE``, else the Jupyter server's root folder
    (what its file browser shows), else the user's home."""
    configured = os.environ.get("ROBOT_SIMS_WORKSPACE", "").strip()
    if configured:
        return Path(configured).expanduser()
    root = jupyter_root()
    return Path(root).expanduser() if root else Path.home()


def jupyter_root() -> str:
    """The running Jupyter server's ``root_dir`` ('' outside one)."""
    app_module = sys.modules.get("jupyter_server.serverapp")  # loaded in a Jupyter server, never imported here
    server_app: Any = getattr(app_module, "ServerApp", None)
    if server_app is None or not server_app.initialized():
        return ""
    return str(server_app.instance().root_dir or "")


def template_safe(text: str) -> str:
    """``text`` through jupyter-server-proxy's ``str.format`` unchanged (a folder named ``{x}``)."""
    return text.replace("{", "{{").replace("}", "}}")


def studio_command(unix_socket: str) -> list[str]:
    """The studio's command line on ``unix_socket`` (jupyter-server-proxy passes it by name): this
    interpreter, so the studio is the one installed beside the Jupyter server."""
    argv = [
        sys.executable,
        "-m",
        "studio",
        "--unix-socket",
        unix_socket,
        "--workspace",
        str(workspace()),
        "--exit-with-parent",
    ]
    return [template_safe(word) for word in argv]


def studio_environment(base_url: str) -> dict[str, str]:
    """What the studio is told beyond the server's environment: its address under the server
    (printed at start instead of a loopback URL nobody could open)."""
    return {"ROBOT_SIMS_PROXY_PATH": template_safe(f"{base_url.rstrip('/')}/{NAME}/")}


def setup_studio() -> dict[str, Any]:
    """jupyter-server-proxy's configuration of the studio (``c.ServerProxy.servers[NAME]``)."""
    return {
        "command": studio_command,
        "environment": studio_environment,
        "unix_socket": True,  # a new 0700 temporary folder of the proxy's, per server
        "timeout": START_TIMEOUT,
        "new_browser_tab": True,
        "launcher_entry": {"title": "robot_sims studio"},
    }
