"""The course server's ``jupyterhub_config.py``, as ``classroom init`` writes it ($-placeholders).

Everything a teacher may want to change is a plain assignment here, with why in a comment; the
logic (accounts, domains, limits, audit) lives in the package, where it is tested.
"""

from string import Template

TEMPLATE = Template("""\
# JupyterHub configuration of a robot_sims course server, written by `robot_sims classroom init`.
# Start it with `robot_sims classroom serve $course` (as root: each student is a Unix user).
# Edit freely; docs/classroom.md explains every part. `init --force` writes it afresh.

COURSE = "$course"  # this folder: the hub's database, cookie secret, domains.json, audit.log
STUDENT_PYTHON = "$student_python"  # the interpreter of the venv every student runs
HUB_PYTHON = "$hub_python"  # the interpreter of the hub's services (the idle culler)

c = get_config()  # noqa: F821 (JupyterHub provides it)

# --- Where it listens -----------------------------------------------------------------------
# The public address: the only port the course server opens to the network. For students on other
# machines use your host's name, and TLS (below or a reverse proxy in front): http:// sends
# passwords in the clear.
c.JupyterHub.bind_url = "$bind_url"
# TLS: c.JupyterHub.bind_url = "https://robots.example.edu:443/" with the certificate files:
# c.JupyterHub.ssl_cert = "/etc/letsencrypt/live/robots.example.edu/fullchain.pem"
# c.JupyterHub.ssl_key = "/etc/letsencrypt/live/robots.example.edu/privkey.pem"
# The hub's internal API and the proxy's API stay on the loopback interface.
c.JupyterHub.hub_bind_url = "http://127.0.0.1:$hub_port"
c.ConfigurableHTTPProxy.api_url = "http://127.0.0.1:$proxy_api_port"
c.JupyterHub.db_url = f"sqlite:///{COURSE}/jupyterhub.sqlite"  # back this file up (docs/classroom.md)
c.JupyterHub.cookie_secret_file = f"{COURSE}/jupyterhub_cookie_secret"
c.ConfigurableHTTPProxy.pid_file = f"{COURSE}/jupyterhub-proxy.pid"

# --- Who may sign in ------------------------------------------------------------------------
# Students sign up at /hub/signup; they can sign in only once the teacher has approved them at
# /hub/authorize (the admin named here is approved on sign-up).
c.JupyterHub.authenticator_class = "sim_tools.classroom.native.ClassroomAuthenticator"  # NativeAuthenticator
c.Authenticator.admin_users = {"$admin"}
c.Authenticator.allow_all = True  # every *approved* user: NativeAuthenticator refuses the others
c.NativeAuthenticator.open_signup = False
c.NativeAuthenticator.minimum_password_length = 10
c.NativeAuthenticator.check_common_password = True
# Sign-in throttled: after this many failed attempts a name is blocked for this many seconds.
c.NativeAuthenticator.allowed_failed_logins = 3
c.NativeAuthenticator.seconds_before_next_try = 600
# The university's single sign-on instead (pip install oauthenticator; docs/classroom.md):
# c.JupyterHub.authenticator_class = "generic-oauth"
# c.GenericOAuthenticator.client_id = "..."; c.GenericOAuthenticator.client_secret = "..."
# c.GenericOAuthenticator.oauth_callback_url = "https://robots.example.edu/hub/oauth_callback"
# c.GenericOAuthenticator.authorize_url / token_url / userdata_url = your identity provider's
# c.GenericOAuthenticator.allowed_groups = {"robotics-101"}

# --- Each student's server ------------------------------------------------------------------
# A real Unix user per student, made on their first start (home /home/<name>, mode 0700, group
# below); an existing account outside that group is refused (no one signs up as "root").
c.JupyterHub.spawner_class = "sim_tools.classroom.spawner.ClassroomSpawner"
c.ClassroomSpawner.student_group = "$group"
c.Spawner.cmd = [STUDENT_PYTHON, "-m", "jupyterhub.singleuser"]
c.Spawner.default_url = "/lab"
c.Spawner.ip = "127.0.0.1"  # reached only through the hub's proxy, never from the network
c.Spawner.disable_user_config = True  # a student's ~/.jupyter cannot change how their server listens
c.Spawner.start_timeout = 120  # a busy machine starts several servers at once
c.Spawner.http_timeout = 120
# Each running server gets its own ROS domain from this range (none left: the start is refused).
c.ClassroomSpawner.domains = "$domains"
c.ClassroomSpawner.domain_state = f"{COURSE}/domains.json"
c.Spawner.environment = {
    "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST",  # DDS never leaves this machine
    "FASTRTPS_DEFAULT_PROFILES_FILE": "$fastdds_profile",
    "AMENT_PREFIX_PATH": "$ament_prefix",
    "ROBOT_SIMS_MAX_WORLDS": "$max_worlds",  # worlds one student's studio may run at once
}
# Limits per student (what each does and does not guarantee: sim_tools/classroom/limits.py).
c.ClassroomSpawner.memory_limit = "$memory"  # RLIMIT_AS per process; a cgroup total where possible
c.ClassroomSpawner.max_processes = $processes  # RLIMIT_NPROC: processes + threads of the user
c.ClassroomSpawner.nice = $nice  # the hub and the proxy keep the CPU first

# --- Idle servers are stopped ---------------------------------------------------------------
c.JupyterHub.services = [
    {
        "name": "idle-culler",
        "command": [HUB_PYTHON, "-m", "jupyterhub_idle_culler", "--timeout=$idle_timeout", "--cull-every=60"],
    }
]
c.JupyterHub.load_roles = [
    {
        "name": "idle-culler",
        "scopes": ["list:users", "read:users:activity", "read:servers", "delete:servers"],
        "services": ["idle-culler"],
    }
]

# --- The teacher's admin actions, audited in {COURSE}/audit.log ------------------------------
from sim_tools.classroom.audit import audited  # noqa: E402

c.JupyterHub.tornado_settings = {"log_function": audited(f"{COURSE}/audit.log")}
# The full log (every request, every spawn) goes to `classroom serve`'s standard error.
""")
