"""The forms a user's controller takes in a sweep, and how an episode runs each one: one small
class per form (:class:`_NodeController`, :class:`_MainController`, :class:`_ModelController`,
:class:`_MfileController`, made by :func:`make_controller`), which :mod:`sim_tools.batch.episode`
sets up, steps and tears down.

- ``node``: an rclpy ``Node`` subclass, with or without ``**kwargs`` in its ``__init__``;
- ``main``: a function callable without arguments (``main()``, ``main(args=None)``) that builds its
  node(s) and spins them: ``rclpy.spin``, a ``rclpy.spin_once`` loop, ``spin_until_future_complete``,
  an executor of its own, or a ``Rate.sleep()`` loop;
- ``model``: ``function(model, params, seed)`` returning ``control(model, t)``;
- ``mfile`` (a Create world's ``use: lab1.m``): ``function lab1(serPort)`` calling the Create
  toolbox, run in GNU Octave against a MATLAB bridge in the episode, the world stepped at real
  time (Octave's ``pause`` is wall-clock), so its episodes are not bit-reproducible.

Every episode runs in its own rclpy context, made rclpy's default for the episode
(:class:`EpisodeContext`), whose command-line arguments carry the controller's parameters
(``--ros-args -p name:=value``): a node built without ``context`` or ``parameter_overrides``, as
``super().__init__("name")`` does, still joins the episode and gets its parameters.

A ``main`` runs in a thread of its own (:class:`MainRunner`) with rclpy's spin functions redirected:
its nodes join the episode's executor, whose callbacks run in the stepping thread, and a spin call
in ``main``'s thread hands the turn to the stepping thread until the sim has moved on (one physics
step for ``spin_once``, the future done for ``spin_until_future_complete``, the rate's timer fired
for ``Rate.sleep``, the episode's end for ``spin``). The two threads never run at the same time:
a ``spin_once`` loop is as deterministic as a callback.
"""

from __future__ import annotations

import inspect
import json
import os
import re
import sysconfig
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, Protocol

from sim_runtime.errors import InputError
from sim_runtime.processes import die_with_parent
from sim_tools.adapters.contract import world_part
from sim_tools.batch.plan import Episode
from sim_tools.matlab.octave import OCTAVE, OCTAVE_NOISE, octave_string

#: What a sweep's ``module:name`` may be, said in every error about one that is none of them.
EXPECTED = (
    "expected a Node subclass, a function main(args=None) that builds its node(s) and spins them "
    "(rclpy.spin, a rclpy.spin_once loop or spin_until_future_complete), "
    "or a model controller function(model, params, seed)"
)
#: Keyword arguments an episode may give a node class's ``__init__``.
NODE_KWARGS = ("context", "parameter_overrides", "namespace", "sensor")
#: Wall seconds ``main`` may run between two spin calls before its episode fails (a loop that
#: never spins, or waits on something only another spinning thread would deliver).
TURN_TIMEOUT = 30.0
#: Our packages: an error's line is the innermost one outside them (and outside Python's and
#: the installed libraries'), the student's.
_OURS = tuple(
    str(Path(__file__).resolve().parents[2] / name) + os.sep
    for name in ("sim_tools", "sim_runtime", "create_sim", "simrobot_sim", "arm_sim", "studio")
)
_LIBRARIES = tuple(
    {str(Path(sysconfig.get_paths()[k]).resolve()) + os.sep for k in ("stdlib", "platstdlib", "purelib", "platlib")}
)
#: Wall seconds ``main`` gets to reach its first wait once another thread of its spins.
OTHERS_GRACE = 2.0
#: Wall seconds to wait for ``main``'s thread to finish once its spin calls have returned.
JOIN_TIMEOUT = 5.0
#: Wall seconds to wait for an episode's publishers and subscriptions to match.
MATCH_TIMEOUT = 10.0

#: Our nodes in an episode go without what nobody can reach there (parameter services, /rosout):
#: leaving them out halved the set-up plus tear-down (median 0.22 -> 0.10 s, measured alternating).
LEAN_NODE: dict[str, Any] = {"start_parameter_services": False, "enable_rosout": False}


def is_user_file(filename: str) -> bool:
    """A file of a user's code: not ours, Python's or an installed library's."""
    if filename.startswith("<"):
        return False
    path = str(Path(filename).resolve())
    return not path.startswith(_OURS) and not path.startswith(_LIBRARIES)


# ------------------------------------------------------------------------------ classification
def classify(obj: Any, target: str) -> str:
    """``node``, ``main`` or ``model`` for the object ``target`` names; InputError otherwise."""
    from rclpy.node import Node

    if isinstance(obj, type):
        if not issubclass(obj, Node):
            raise InputError(f"{target}: class {obj.__name__} is not an rclpy Node subclass; {EXPECTED}")
        missing = _required(obj) - set(NODE_KWARGS)
        if missing:
            raise InputError(
                f"{target}: {obj.__name__}.__init__ needs {', '.join(sorted(missing))}, which an episode cannot "
                f"give (it passes nothing, or context, parameter_overrides and namespace through **kwargs)"
            )
        return "node"
    if not callable(obj):
        raise InputError(f"{target}: a {type(obj).__name__}, not a class or function; {EXPECTED}")
    if _binds(obj, 0):
        return "main"
    if _binds(obj, 3):
        return "model"
    raise InputError(f"{target}: {_signature_text(obj)} takes neither no arguments nor 3; {EXPECTED}")


def _binds(func: Callable[..., Any], count: int) -> bool:
    try:
        inspect.signature(func).bind(*range(count))
    except TypeError:
        return False
    except ValueError:  # no signature (a builtin): assume the common case
        return count == 0
    return True


def _required(cls: type) -> set[str]:
    """Names the class's constructor needs and has no default for."""
    try:
        params = inspect.signature(cls).parameters.values()
    except (TypeError, ValueError):
        return set()
    kinds = (inspect.Parameter.POSITIONAL_ONLY, inspect.Parameter.POSITIONAL_OR_KEYWORD, inspect.Parameter.KEYWORD_ONLY)
    return {p.name for p in params if p.kind in kinds and p.default is inspect.Parameter.empty}


def _signature_text(func: Callable[..., Any]) -> str:
    try:
        return f"{getattr(func, '__name__', 'it')}{inspect.signature(func)}"
    except (TypeError, ValueError):
        return repr(func)


def node_kwargs(cls: type, wanted: dict[str, Any]) -> dict[str, Any]:
    """The part of ``wanted`` that ``cls(...)`` accepts: all of it with ``**kwargs``, else what it names."""
    try:
        params = inspect.signature(cls).parameters
    except (TypeError, ValueError):
        return dict(wanted)
    if any(p.kind is inspect.Parameter.VAR_KEYWORD for p in params.values()):
        return dict(wanted)
    return {k: v for k, v in wanted.items() if k in params}


def ros_args(params: dict[str, Any]) -> list[str]:
    """``--ros-args -p name:=value ...`` for rclpy.init: YAML values, which JSON's are."""
    return ["batch", "--ros-args"] + [a for k, v in params.items() for a in ("-p", f"{k}:={json.dumps(v)}")]


def declared(nodes: list[Any]) -> dict[str, Any]:
    """Every parameter the nodes declared, with its rclpy type."""
    out: dict[str, Any] = {}
    for node in nodes:
        for name in node.list_parameters([], 0).names:
            out[name] = node.get_parameter(name).type_
    return out


# --------------------------------------------------------------------------------- the context
class EpisodeContext:
    """A fresh rclpy context on ``domain_id`` with ``args``, rclpy's default one until :meth:`close`."""

    def __init__(self, args: list[str], domain_id: int | None) -> None:
        import rclpy
        import rclpy.utilities
        from rclpy.context import Context

        self.context = Context()
        rclpy.init(args=args, context=self.context, domain_id=domain_id)
        with rclpy.utilities.g_context_lock:
            self._previous: Context | None = rclpy.utilities.g_default_context
            rclpy.utilities.g_default_context = self.context  # type: ignore[assignment]

    def close(self) -> None:
        import rclpy
        import rclpy.utilities

        with rclpy.utilities.g_context_lock:
            if rclpy.utilities.g_default_context is self.context:
                rclpy.utilities.g_default_context = self._previous
        rclpy.shutdown(context=self.context)


# ------------------------------------------------------------------------------------ a main()
class MainStuck(RuntimeError):
    """``main`` did not come back to a spin call in :data:`TURN_TIMEOUT` (the message says where it is)."""

    located = True  # the message names the student's line: no "(at forms.py:...)" after it


class NotSpinning(RuntimeError):
    """``main`` did not spin a node in time (it may be waiting for something only a world sends)."""


class MainRunner:
    """Runs a user's ``main()`` in a thread, in turns with the stepping thread (see the module)."""

    def __init__(self, main: Callable[..., Any], target: str) -> None:
        self.main = main
        self.target = target
        self.stepper = threading.get_ident()
        self.cond = threading.Condition()
        self.nodes: list[Any] = []
        self.added = 0  # nodes already handed to the episode's executor
        self.steps = 0
        self.sim_time = 0.0
        self.finished = False  # the episode is over: every spin returns
        self.parked = False  # main's thread waits in a spin call: the stepping thread's turn
        self.release: Callable[[], bool] = lambda: False  # when its spin call returns
        self.ended = False  # main returned or raised
        self.others = False  # another thread of main's waits in a spin call
        self.error: BaseException | None = None
        self.thread: threading.Thread | None = None
        self._saved: list[tuple[Any, str, Any]] = []
        self.created: list[Any] = []  # every node main's threads built

    # -- the stepping thread ------------------------------------------------------------------
    def start(self, timeout: float) -> list[Any]:
        """Start ``main`` and wait until it spins; returns its nodes."""
        self._patch()
        self.thread = threading.Thread(target=self._run, name="controller main()", daemon=True)
        self.thread.start()
        with self.cond:
            self.cond.wait_for(lambda: self.parked or self.ended or self.others, timeout=timeout)
            # a thread of main's spins: give main itself a moment to reach its own first wait (a
            # rate.sleep()), so that it too starts in turns
            self.cond.wait_for(lambda: self.parked or self.ended, timeout=OTHERS_GRACE)
            if self.error is not None:
                raise self.error
            if not self.nodes:
                why = "returned" if self.ended else f"did not get there within {timeout:g} s"
                raise (InputError if self.ended else NotSpinning)(
                    f"{self.target} {why} before spinning a node: an episode runs the nodes that main() gives "
                    "rclpy.spin, rclpy.spin_once or rclpy.spin_until_future_complete"
                )
        return self.new_nodes()

    def new_nodes(self) -> list[Any]:
        """Nodes ``main`` has spun since the last call."""
        with self.cond:
            fresh = self.nodes[self.added :]
            self.added = len(self.nodes)
        return fresh

    def after_step(self, sim_time: float) -> bool:
        """The sim moved on: give ``main`` its turn if its spin call is over, and wait until it
        spins again (or ends); True if it had a turn."""
        with self.cond:
            self.steps += 1
            self.sim_time = sim_time
            self.cond.notify_all()  # spin calls in other threads of main's
            if not (self.parked and self.release()):
                return False
            self.parked = False
            self.cond.notify_all()
            if not self.cond.wait_for(lambda: self.parked or self.ended, timeout=TURN_TIMEOUT):
                raise MainStuck(
                    f"{self.target} ran {TURN_TIMEOUT:g} s of wall time without coming back to a spin call "
                    f"(a loop that never spins, or a wait that needs another thread spinning){self._where()}, "
                    f"at sim time {sim_time:g} s"
                )
            if self.error is not None:
                raise self.error
            return True

    def _where(self) -> str:
        """``; main() is in loop() of student.py``: where ``main``'s thread is now, in the
        student's code (its whole stack, lines included, goes to the episode's log: the row names
        the function, as a loop is on one line or the next from run to run)."""
        import sys
        import traceback

        ident = self.thread.ident if self.thread is not None else None
        frame = sys._current_frames().get(ident) if ident is not None else None
        stack = traceback.extract_stack(frame) if frame is not None else []
        if stack:
            print(f"{self.target}: main()'s thread, stopped:", file=sys.stderr)
            traceback.print_list(stack, file=sys.stderr)
        user = next((f for f in reversed(stack) if is_user_file(f.filename)), None)
        return f"; main() is in {user.name}() of {Path(user.filename).name}" if user else ""

    def stop(self) -> None:
        """End the episode for ``main``: its spin calls return (``spin_once`` raises rclpy's
        ExternalShutdownException, as after a Ctrl-C) and its thread is joined."""
        with self.cond:
            self.finished = True
            self.parked = False
            self.cond.notify_all()
        if self.thread is not None:
            self.thread.join(timeout=JOIN_TIMEOUT)
        for owner, name, value in self._saved:
            setattr(owner, name, value)
        self._saved = []
        for node in self.created:  # made but never spun: nobody else destroys them
            if node not in self.nodes:
                node.destroy_node()

    def _run(self) -> None:
        try:
            self.main()
        except BaseException as exc:  # sys.exit too: the episode reports it
            with self.cond:
                if not self.finished:
                    self.error = exc
        finally:
            with self.cond:
                self.ended = True
                self.cond.notify_all()

    # -- main's threads -----------------------------------------------------------------------
    def _wait(self, nodes: list[Any], release: Callable[[], bool], *, park: bool = True) -> bool:
        """Take ``nodes`` into the episode and park in a spin call until ``release()`` after a
        step (or the episode's end); False when the episode is over."""
        with self.cond:
            for node in nodes:
                if node is not None and node not in self.nodes:
                    self.nodes.append(node)
            self.cond.notify_all()
            if self.finished or not park:
                return not self.finished
            if threading.current_thread() is self.thread:
                self.release, self.parked = release, True
                self.cond.notify_all()
                self.cond.wait_for(lambda: not self.parked or self.finished)
            else:  # another thread of main's: not in turns, it just waits for its condition
                self.others = True
                self.cond.notify_all()
                self.cond.wait_for(lambda: self.finished or release())
            return not self.finished

    def _after(self, steps: int) -> Callable[[], bool]:
        start = self.steps
        return lambda: self.steps >= start + steps

    def _until(self, future: Any, timeout_sec: float | None) -> Callable[[], bool]:
        end = None if timeout_sec is None or timeout_sec < 0 else self.sim_time + timeout_sec
        return lambda: future.done() or (end is not None and self.sim_time >= end - 1e-9)

    def spin(self, node: Any, executor: Any = None) -> None:
        self._wait([node], lambda: False)

    def spin_once(self, node: Any, *, executor: Any = None, timeout_sec: float | None = None) -> None:
        from rclpy.executors import ExternalShutdownException

        if not self._wait([node], self._after(1)):
            raise ExternalShutdownException()

    def spin_until_future_complete(
        self, node: Any, future: Any, executor: Any = None, timeout_sec: float | None = None
    ) -> None:
        self._wait([node], self._until(future, timeout_sec))

    def rate_sleep(self, rate: Any) -> None:
        """``Rate.sleep``: a turn until the rate's timer fires (on sim time, in the episode's
        executor), where rclpy would need another thread spinning."""
        from rclpy.exceptions import ROSInterruptException

        if not self._wait([], rate._event.is_set):
            raise ROSInterruptException()
        rate._event.clear()

    # -- the redirection ----------------------------------------------------------------------
    def _patch(self) -> None:
        """Redirect rclpy's spin functions, and those of executors main makes, in every thread but
        the stepping one (which keeps the originals)."""
        import rclpy
        from rclpy.executors import Executor, MultiThreadedExecutor, SingleThreadedExecutor
        from rclpy.timer import Rate

        runner = self
        module: dict[str, Callable[..., Any]] = {
            "init": lambda *a, **k: None,
            "shutdown": lambda *a, **k: None,
            "try_shutdown": lambda *a, **k: None,
            "ok": lambda *a, **k: not runner.finished,
            "spin": self.spin,
            "spin_once": self.spin_once,
            "spin_until_future_complete": self.spin_until_future_complete,
        }
        for name, replacement in module.items():
            self._redirect(rclpy, name, replacement, bound=False)
        self._track_nodes()
        self._redirect(Rate, "sleep", self.rate_sleep, bound=True)

        def add_node(_executor: Any, node: Any) -> bool:
            runner._wait([node], lambda: True, park=False)
            return True

        def executor_spin(_executor: Any) -> None:
            runner._wait([], lambda: False)

        def executor_spin_once(_executor: Any, timeout_sec: float | None = None) -> None:
            from rclpy.executors import ExternalShutdownException

            if not runner._wait([], runner._after(1)):
                raise ExternalShutdownException()

        def executor_until(_executor: Any, future: Any, timeout_sec: float | None = None) -> None:
            runner._wait([], runner._until(future, timeout_sec))

        methods: dict[str, Callable[..., Any]] = {
            "add_node": add_node,
            "spin": executor_spin,
            "spin_once": executor_spin_once,
            "spin_until_future_complete": executor_until,
        }
        # main's own executors: their nodes join the episode's executor instead (a node belongs
        # to one executor), and their spin calls take turns like rclpy's.
        for cls in (Executor, SingleThreadedExecutor, MultiThreadedExecutor):
            for name, replacement in methods.items():
                if name in vars(cls):
                    self._redirect(cls, name, replacement, bound=True)

    def _track_nodes(self) -> None:
        """Note every node main's threads build, spun or not (see :meth:`stop`)."""
        from rclpy.node import Node

        original = Node.__init__
        self._saved.append((Node, "__init__", original))
        stepper, created = self.stepper, self.created

        def init(node: Any, *args: Any, **kwargs: Any) -> None:
            original(node, *args, **kwargs)
            if threading.get_ident() != stepper:
                created.append(node)

        Node.__init__ = init  # type: ignore[method-assign,assignment]

    def _redirect(self, owner: Any, name: str, replacement: Callable[..., Any], *, bound: bool) -> None:
        original = getattr(owner, name)
        self._saved.append((owner, name, original))
        stepper = self.stepper

        if bound:

            def method(obj: Any, *args: Any, **kwargs: Any) -> Any:
                if threading.get_ident() == stepper:
                    return original(obj, *args, **kwargs)
                return replacement(obj, *args, **kwargs)

            setattr(owner, name, method)
        else:

            def function(*args: Any, **kwargs: Any) -> Any:
                if threading.get_ident() == stepper:
                    return original(*args, **kwargs)
                return replacement(*args, **kwargs)

            setattr(owner, name, function)


# ---------------------------------------------------------------------------------- an m-file
NO_OCTAVE = f"m-file controllers need GNU Octave: {OCTAVE} not found (apt install octave octave-instrument-control)"
#: Wall seconds Octave may take to start, load the toolbox and connect to the episode's bridge:
#: a cold start took 1-3 s here, many more on a machine loaded with other runs.
OCTAVE_START_TIMEOUT = 60.0
#: Wall seconds an m-file episode's world may fall behind real time and still catch up; held up
#: longer, it goes on at real time from there (:meth:`_MfileController.after_step`).
REAL_TIME_SLACK_S = 0.05
#: Wall seconds a killed Octave may take to be reaped.
OCTAVE_REAP_TIMEOUT = 10.0
#: What the episode's script prints once the program has its serPort, and once the program returned
#: (an Octave that ends without it exited: ``exit`` in the program, or a crash).
CONNECTED = "robot_sims: the program starts"
RETURNED = "robot_sims: the program returned"
#: A killed Octave would otherwise write an octave-workspace file into the program's folder.
NO_CORE = "crash_dumps_octave_core(false); sigterm_dumps_octave_core(false); sighup_dumps_octave_core(false);"
#: Octave's lines kept for the error message (the rest of a flood of output is only in the log).
OCTAVE_LINES_KEPT = 200
_FRAME = re.compile(r"^\s+(\S+) at line (\d+)")
_DEFINES = re.compile(r"^\s*function\s+(?:[^=\n]*=\s*)?(\w+)", re.MULTILINE)


class OctaveError(RuntimeError):
    """The m-file failed (Octave's message), exited, or Octave did not start."""

    located = True  # the message names the program's line when Octave does


def octave_script(program: Path, port: int) -> str:
    """Octave's ``--eval``: the Create toolbox and the program's folder on the path, the handle
    connected to the bridge on ``port``, ``prog(serPort)``, and the markers around it."""
    from sim_tools.matlab.paths import matlab_dir

    def say(text: str) -> str:
        return f"disp({octave_string(text)}); fflush(stdout);"

    return (
        f"{NO_CORE} more off; addpath({octave_string(str(matlab_dir()))}); "
        f"addpath({octave_string(str(program.parent))}); serPort = CreateRobot({port}); {say(CONNECTED)} "
        f"{program.stem}(serPort); {say(RETURNED)} clear serPort;"
    )


def octave_error(lines: list[str], program: Path) -> str:
    """Octave's error message from its output ('' if none): the first ``error:`` line (a parse
    error's reason after it), the program's file for its path, and the innermost line of the
    program (not the toolbox's) that the call stack names."""
    for k, line in enumerate(lines):
        if line.startswith("error:") and not line.startswith(OCTAVE_NOISE):
            message = line.removeprefix("error:").strip().replace(str(program), program.name)
            rest = [x.strip() for x in lines[k + 1 : k + 4] if x.strip()]
            if message.startswith("parse error") and rest:
                message += f": {rest[0]}"
            return message + _program_frame(lines[k + 1 :], program)
    return ""


def _program_frame(lines: list[str], program: Path) -> str:
    """`` (at lab1.m:5, in lab1)``: the innermost frame of Octave's call stack in the program's
    file (its functions, or its name: Octave calls a function file by its name)."""
    try:
        own = set(_DEFINES.findall(program.read_text(errors="replace"))) | {program.stem}
    except OSError:
        own = {program.stem}
    for line in lines:
        match = _FRAME.match(line)
        if match and match.group(1).split(">")[0] in own:
            return f" (at {program.name}:{match.group(2)}, in {match.group(1)})"
    return ""


class OctaveProgram:
    """``octave-cli`` running one m-file program against the bridge on ``port`` (the key in its
    environment, never its arguments), in a session of its own; its output goes to the episode's
    log (stderr) as it comes."""

    def __init__(self, program: Path, port: int, key: str) -> None:
        import collections
        import shutil
        import subprocess

        from sim_tools.matlab.bridge import KEY_ENV

        if shutil.which(OCTAVE) is None:
            raise InputError(NO_OCTAVE)
        self.program = program
        self.lines: collections.deque[str] = collections.deque(maxlen=OCTAVE_LINES_KEPT)
        self.cond = threading.Condition()
        self.connected = self.ended = self.checked = False
        self.process = subprocess.Popen(
            [OCTAVE, "--no-gui", "--quiet", "--no-history", "--eval", octave_script(program, port)],
            cwd=program.parent,
            env={**os.environ, KEY_ENV: key},
            stdin=subprocess.DEVNULL,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            # a group of its own (killed whole: what the program started with system() too), in
            # the worker's session; and it dies with the worker (batch kills a worker's group at
            # an episode's time limit, which Octave's group is not)
            process_group=0,
            preexec_fn=die_with_parent(os.getpid()),
        )
        self.reader = threading.Thread(target=self._read, name="octave output", daemon=True)
        self.reader.start()

    def _read(self) -> None:
        import sys

        assert self.process.stdout is not None
        for raw in self.process.stdout:
            line = raw.decode(errors="replace").rstrip("\n")
            print(f"octave: {line}", file=sys.stderr, flush=True)
            with self.cond:
                self.lines.append(line)
                self.connected = self.connected or line == CONNECTED
                self.cond.notify_all()
        with self.cond:
            self.ended = True
            self.cond.notify_all()

    def wait_connected(self, sim_time: float) -> None:
        """Return once the program has its serPort; OctaveError if Octave ended or is slow."""
        with self.cond:
            self.cond.wait_for(lambda: self.connected or self.ended, timeout=OCTAVE_START_TIMEOUT)
        if self.connected:
            return
        if self.process.poll() is None:
            raise OctaveError(f"Octave did not start {self.program.name} within {OCTAVE_START_TIMEOUT:g} s")
        self.check(sim_time)

    def check(self, sim_time: float) -> None:
        """OctaveError once Octave has ended without the program returning (at most once)."""
        if self.checked or self.process.poll() is None:
            return
        self.checked = True
        self.reader.join(timeout=JOIN_TIMEOUT)  # its last lines
        lines = list(self.lines)
        if RETURNED in lines:
            return  # it returned: the bridge has stopped the robot, the episode goes on
        raise OctaveError(f"{octave_error(lines, self.program) or self._ended()}, at sim time {sim_time:g} s")

    def _ended(self) -> str:
        status = self.process.returncode
        if status < 0:
            return f"Octave was killed by signal {-status} before {self.program.name} returned"
        return f"{self.program.name} called exit({status}) before returning (Octave ended)"

    def kill(self) -> None:
        """Octave and what it started, at once (a program blocked in a toolbox call ignores SIGINT)."""
        import contextlib
        import signal
        import subprocess

        if self.process.poll() is None:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(self.process.pid, signal.SIGKILL)
        with contextlib.suppress(subprocess.TimeoutExpired):
            self.process.wait(timeout=OCTAVE_REAP_TIMEOUT)
        self.reader.join(timeout=JOIN_TIMEOUT)


# ------------------------------------------------------------------------ an episode's controller
class EpisodeTurn(Protocol):
    """What a controller sees of the running episode between two steps (batch.episode's run)."""

    world: Any
    executor: Any
    deliver: Callable[[], Any]


class _NodeController:
    """Node classes (our executables' and users'), placed in the world by its adapter."""

    def __init__(self, ep: Episode, cls: type, params: dict[str, Any], context: Any) -> None:
        self.ep, self.cls, self.params, self.context = ep, cls, params, context
        self.nodes: list[Any] = []

    def start(self, world: Any) -> list[Any]:
        def make(cls: type, **extra: str) -> Any:
            return controller_node(self.ep, cls, self.params, self.context, **extra)

        part = world_part(self.ep.simulator)
        self.nodes = part.controller_nodes(self.cls, world, self.ep.world, make, context=self.context, **LEAN_NODE)
        return self.nodes

    def auto_transport(self) -> str:
        """Ours take the direct bus; a user's node class DDS, unless the world placed none."""
        return "direct" if self.ep.controller["kind"] == "ours" or not self.nodes else "ros"

    def before_step(self, world: Any) -> None:
        """Nodes act on the messages they receive."""

    def after_step(self, run: EpisodeTurn) -> None:
        """Nodes act on the messages they receive."""

    def stop(self) -> None:
        """The episode's executor destroys the nodes."""


class _MainController:
    """A user's ``main()``, in a thread of its own, in turns with the stepping (:class:`MainRunner`)."""

    def __init__(self, main: Any, target: str) -> None:
        self.main, self.target = main, target
        self.runner: Any = None

    def start(self, world: Any) -> list[Any]:
        self.runner = MainRunner(self.main, self.target)
        return self.runner.start(MATCH_TIMEOUT)

    def auto_transport(self) -> str:
        return "ros"

    def before_step(self, world: Any) -> None:
        """``main`` takes its turn after the step."""

    def after_step(self, run: EpisodeTurn) -> None:
        """``main``'s turn: nodes it spun for the first time join the executor, and what it
        published is delivered."""
        if self.runner.after_step(run.world.sim_time):
            for node in self.runner.new_nodes():
                run.executor.add_node(node)
            run.deliver()

    def stop(self) -> None:
        if self.runner is not None:
            self.runner.stop()  # before shutdown: its thread may still destroy its nodes


class _ModelController:
    """A model function: ``make(model, params, seed)`` returns ``control(model, t)``, called
    before every step."""

    def __init__(self, ep: Episode, make: Any, params: dict[str, Any]) -> None:
        self.ep, self.make, self.params = ep, make, params
        self.control: Any = None

    def start(self, world: Any) -> list[Any]:
        self.control = self.make(world.model, dict(self.params), self.ep.seed)
        if not callable(self.control):
            raise InputError(
                f"controller {self.ep.controller['target']}: must return a per-step callable control(model, t)"
            )
        return []

    def auto_transport(self) -> str:
        return "direct"

    def before_step(self, world: Any) -> None:
        self.control(world.model, world.sim_time)

    def after_step(self, run: EpisodeTurn) -> None:
        """Nothing runs between steps."""

    def stop(self) -> None:
        """Nothing to stop."""


class _MfileController:
    """An m-file program ``function prog(serPort)`` in GNU Octave (:class:`OctaveProgram`), driving
    the robot through a MATLAB bridge (:class:`sim_tools.matlab.bridge.MatlabBridge`) whose node
    joins the episode: the world steps at real time, as Octave's ``pause`` counts wall seconds."""

    def __init__(self, ep: Episode, program: Path, context: Any) -> None:
        self.ep, self.program, self.context = ep, program, context
        self.bridge: Any = None
        self.octave: OctaveProgram | None = None
        self.started: float | None = None  # monotonic, at sim time 0: when each later step is due
        self.held_up = 0.0  # wall seconds the world fell behind the wall clock and did not make up

    def start(self, world: Any) -> list[Any]:
        from rclpy.node import Node

        from sim_tools.matlab.bridge import MatlabBridge, new_key

        key = new_key()  # the bridge serves only this episode's Octave, though any local user can connect
        node = Node("matlab_bridge", context=self.context, **LEAN_NODE)
        self.bridge = MatlabBridge(node=node, port=0, key=key)
        # Octave starts now (it takes a second or more) but its calls wait for the first step: a
        # call made while the episode's recorder is still subscribing would be lost to the bag.
        self.bridge.hold_calls()
        self.bridge.start()
        self.octave = OctaveProgram(self.program, self.bridge.port, key)
        return [node]

    def auto_transport(self) -> str:
        return "ros"  # the bridge's calls publish from its session's thread: never the direct bus

    def before_step(self, world: Any) -> None:
        """The program acts from Octave's own thread of time (see :meth:`after_step`)."""

    def after_step(self, run: EpisodeTurn) -> None:
        """After the first step (which may wait seconds for a recorder to attach, while Octave starts
        meanwhile): wait for the program to start, so that its time and the sim's run together.
        After every step: wait for the wall clock to reach the sim's time, take in what the program
        sent meanwhile, and fail if Octave failed or exited. A world held up (a busy machine) goes
        on at real time from where it is, as a paused one would, never in a burst: a burst would
        run the sim on under a command the program meant for a shorter wall time."""
        if self.octave is None:
            return
        if self.started is None:
            self.bridge.serve_calls()
            self.octave.wait_connected(run.world.sim_time)
            self.started = time.monotonic() - run.world.sim_time
        behind = time.monotonic() - self.started - run.world.sim_time
        if behind > REAL_TIME_SLACK_S:
            self.started += behind
            self.held_up += behind
        elif behind < 0:
            time.sleep(-behind)
            run.deliver()
        self.octave.check(run.world.sim_time)

    def stop(self) -> None:
        """Octave killed (a program may loop for ever, or block in a toolbox call), then the bridge
        closed: it stops the robot."""
        if self.octave is not None:
            self.octave.kill()
        if self.bridge is not None:
            self.bridge.close()
        if self.held_up > REAL_TIME_SLACK_S:
            import sys

            print(f"m-file: the world was held up {self.held_up:.2f} s of wall time behind real time", file=sys.stderr)


Controller = _NodeController | _MainController | _ModelController | _MfileController


def make_controller(form: str, ep: Episode, obj: Any, params: dict[str, Any], context: Any) -> Controller:
    """The controller of ``form`` (:func:`controller_form`)."""
    if form == "mfile":
        return _MfileController(ep, obj, context)
    if form == "main":
        return _MainController(obj, ep.controller["target"])
    if form == "node":
        return _NodeController(ep, obj, params, context)
    return _ModelController(ep, obj, params)


def load_controller(ep: Episode) -> tuple[str, Any]:
    """The form of ``ep``'s controller and what it runs: the imported object, or an m-file's path."""
    from sim_tools.batch.metrics import load_callable

    if ep.controller["kind"] == "mfile":
        return "mfile", Path(ep.controller["target"])
    obj = load_callable(ep.controller["target"], ep.search_path)
    return controller_form(ep, obj), obj


def controller_form(ep: Episode, obj: Any) -> str:
    """``node``, ``main`` or ``model`` (:func:`sim_tools.batch.forms.classify`); ours are nodes."""
    form = "node" if ep.controller["kind"] == "ours" else classify(obj, ep.controller["target"])
    part = world_part(ep.simulator)
    if form == "node" and part.ROBOT_NAMESPACES and "namespace" not in node_kwargs(obj, {"namespace": ""}):
        raise InputError(
            f"{ep.controller['target']}: a {part.LABEL} controller class runs once per robot, each in its "
            "robot's namespace: give its __init__ **kwargs and pass them to super().__init__"
        )
    return form


def controller_parameters(ep: Episode, params: dict[str, Any]) -> dict[str, Any]:
    """What every controller node of ``ep`` gets: sim time, the episode's seed, the sweep's values.

    Our controllers read the messages' stamps, never a clock, and run on sim time only if they
    have timers (:func:`controller_node`): the world's ``/clock`` delivered to a node every step
    made a bump-and-turn episode's run 37 % longer on the direct bus (median 0.244 -> 0.334 s per
    20 s episode, alternating, 8 each)."""
    sim_time = {} if ep.controller["kind"] == "ours" else {"use_sim_time": True}
    return {**sim_time, "seed": ep.seed, **params}


def controller_args(ep: Episode, params: dict[str, Any]) -> list[str]:
    """The episode context's command line: the controller parameters for every node that reads
    them from there (a class without ``**kwargs``, the nodes of a ``main``); ours take them as
    ``parameter_overrides``."""
    return ros_args(controller_parameters(ep, params) if ep.controller["kind"] == "user" else {})


def controller_node(ep: Episode, cls: type, params: dict[str, Any], context: Any, **extra: str) -> Any:
    """One node of class ``cls``, given what its ``__init__`` accepts; what it does not (a class
    without ``**kwargs``) it finds in the episode context's arguments, rclpy's default context.
    ``extra`` is what the world's adapter places the node with (``namespace``, ``sensor``)."""
    from rclpy.node import Node
    from rclpy.parameter import Parameter

    overrides = [Parameter(k, value=v) for k, v in controller_parameters(ep, params).items()]
    kwargs = node_kwargs(cls, {"parameter_overrides": overrides, "context": context, **extra})
    for key in set(extra) - _init_args(cls) - _init_args(Node):
        kwargs.pop(key, None)  # **kwargs go on to Node, which takes no such argument
    if ep.controller["kind"] != "ours":
        return cls(**kwargs)
    node = cls(**kwargs, **LEAN_NODE)
    if list(node.timers):
        node.set_parameters([Parameter("use_sim_time", value=True)])
    return node


def _init_args(cls: type) -> set[str]:
    import inspect

    try:
        return set(inspect.signature(cls).parameters)
    except (TypeError, ValueError):
        return set()
