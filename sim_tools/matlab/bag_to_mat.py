"""``bag_to_mat BAG [-o run.mat] [--topics /r1/odom ...]``: a recorded run as a MATLAB ``.mat`` file.

``d = load('run.mat')`` gives one struct per topic, named after it (``/r1/odom`` → ``d.r1_odom``,
``/odom`` → ``d.odom``), with one row per message: ``t`` (the header stamp in s, i.e. sim time; the
recording time for a message without a header), ``t_recorded`` (recording time, s since 1970),
every numeric field of the message flattened with ``_`` (``pose_pose_position_x``; arrays as
matrix rows, or a cell column when their length varies) and its strings once (the first
message's; a cell column when they change, e.g. ``std_msgs/String``'s ``data``). Poses also get
``x``, ``y``, ``theta`` (yaw, rad), velocities ``v``, ``omega``. ``d.topics`` lists {struct name,
topic, type}. A Create's ground truth (``overhead_pose``) is also written as the original
simulator's ``datahistory`` cell array: {time, x, y, angle, calls} per row, the calls from the
MATLAB bridge's ``matlab_calls`` in the same namespace when the bag has it.
"""

from __future__ import annotations

import argparse
import bisect
import math
import re
import sys
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np

from create_sim.spec import OVERHEAD_POSE_TOPIC
from sim_runtime.bag.reader import CorruptMessage, UnknownMessageType, open_bag
from sim_runtime.errors import InputError

#: Longest MATLAB variable or field name.
MAX_NAME = 63
#: Friendly names of common fields (flattened name → short name), when a message has them.
ALIASES = {
    "pose_position_x": "x",
    "pose_position_y": "y",
    "pose_pose_position_x": "x",
    "pose_pose_position_y": "y",
    "twist_twist_linear_x": "v",
    "twist_twist_angular_z": "omega",
    "twist_linear_x": "v",
    "twist_angular_z": "omega",
    "linear_x": "v",
    "angular_z": "omega",
}
#: Quaternion prefixes whose yaw becomes ``theta``.
YAW_FROM = ("pose_orientation", "pose_pose_orientation")


def mat_name(topic: str, taken: set[str]) -> str:
    """A MATLAB name for ``topic``: letters, digits and _, starting with a letter, unique."""
    name = re.sub(r"[^A-Za-z0-9_]", "_", topic).strip("_") or "topic"
    if not name[0].isalpha():
        name = "t_" + name
    name = name[:MAX_NAME]
    base, k = name, 2
    while name in taken:
        suffix = f"_{k}"
        name, k = base[: MAX_NAME - len(suffix)] + suffix, k + 1
    taken.add(name)
    return name


def _is_message(value: Any) -> bool:
    return hasattr(type(value), "get_fields_and_field_types")


def flatten(msg: Any, prefix: str = "", out: dict[str, Any] | None = None) -> dict[str, Any]:
    """Numbers, numeric arrays and strings of ``msg`` by ``_``-joined field path (lists of messages
    are left out: e.g. markers, transforms)."""
    out = {} if out is None else out
    for field in type(msg).get_fields_and_field_types():
        value = getattr(msg, field)
        key = f"{prefix}{field}"
        if _is_message(value):
            flatten(value, key + "_", out)
        elif isinstance(value, (bool, int, float)):
            out[key] = float(value)
        elif isinstance(value, str):
            out[key] = value
        elif isinstance(value, (bytes, bytearray)):
            out[key] = np.frombuffer(bytes(value), dtype=np.uint8).astype(float)
        elif len(value) and all(isinstance(v, str) for v in value):
            out[key] = list(value)
        elif not len(value) or not _is_message(value[0]):
            out[key] = np.asarray(value, dtype=float).reshape(-1)
    return out


def _yaw(q: dict[str, float], prefix: str) -> float:
    x, y, z, w = (q[f"{prefix}_{c}"] for c in "xyzw")
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


class TopicTable:
    """The rows of one topic, gathered message by message."""

    def __init__(self, topic: str, type_name: str) -> None:
        self.topic = topic
        self.type = type_name
        self.t: list[float] = []
        self.t_recorded: list[float] = []
        self.columns: dict[str, list[Any]] = {}
        self.strings: dict[str, list[Any]] = {}  # each message's

    def add(self, msg: Any, log_time_ns: int) -> None:
        """One message: its times and fields."""
        fields = flatten(msg)
        self.t_recorded.append(log_time_ns * 1e-9)
        if "header_stamp_sec" in fields:
            self.t.append(fields["header_stamp_sec"] + fields["header_stamp_nanosec"] * 1e-9)
        else:
            self.t.append(log_time_ns * 1e-9)
        for prefix in YAW_FROM:
            if f"{prefix}_w" in fields:
                fields["theta"] = _yaw(fields, prefix)
        for long, short in ALIASES.items():
            if long in fields and short not in fields:
                fields[short] = fields[long]
        for key, value in fields.items():
            if isinstance(value, (str, list)):
                self.strings.setdefault(key, []).append(value)
            elif not key.startswith("header_stamp"):
                self.columns.setdefault(key, []).append(value)

    def struct(self) -> dict[str, Any]:
        """The topic as a MATLAB struct (a dict for scipy.io.savemat)."""
        out: dict[str, Any] = {"t": np.array(self.t), "t_recorded": np.array(self.t_recorded), "type": self.type}
        taken = set(out)
        for key, values in self.columns.items():
            if len(values) != len(self.t):
                continue  # a field only some messages have (never for one message type)
            out[mat_name(key, taken)] = _stack(values)
        for key, values in self.strings.items():
            out[mat_name(key, taken)] = _strings(values) if len(values) == len(self.t) else _string(values[0])
        return out


def _string(value: str | list[str]) -> Any:
    return np.array(value, dtype=object) if isinstance(value, list) else value


def _strings(values: list[Any]) -> Any:
    """Once (the first message's) when every message has the same; else a cell column."""
    if all(v == values[0] for v in values):
        return _string(values[0])
    cells = np.empty((len(values), 1), dtype=object)
    for i, v in enumerate(values):
        cells[i, 0] = _string(v)
    return cells


def _stack(values: list[Any]) -> np.ndarray:
    # numbers → a column; arrays of one length → rows of a matrix; else a cell column
    if isinstance(values[0], float):
        return np.array(values, dtype=float).reshape(-1, 1)
    if len({len(v) for v in values}) == 1:
        return np.vstack(values) if len(values[0]) else np.zeros((len(values), 0))
    cells = np.empty((len(values), 1), dtype=object)
    for i, v in enumerate(values):
        cells[i, 0] = np.asarray(v, dtype=float).reshape(1, -1)
    return cells


def read_tables(bag_path: str | Path, topics: Iterable[str] | None = None) -> tuple[list[TopicTable], list[str]]:
    """Every topic's table (in the bag's topic order) and the topics left out, each with why."""
    bag = open_bag(bag_path)
    wanted = list(bag.topics) if topics is None else list(topics)
    unknown = [t for t in wanted if t not in bag.topics]
    if unknown:
        raise InputError(f"{bag_path}: no topic {', '.join(unknown)} in the bag; it has {', '.join(bag.topics)}")
    tables = {t: TopicTable(t, bag.topics[t]) for t in wanted}
    skipped: dict[str, str] = {}
    for m in bag.messages(topics=wanted):
        if m.topic in skipped:
            continue
        try:
            tables[m.topic].add(m.msg, m.log_time_ns)
        except (UnknownMessageType, CorruptMessage) as err:
            skipped[m.topic] = str(err)
    kept = [tables[t] for t in wanted if t not in skipped and tables[t].t]
    return kept, [f"{t}: {why}" for t, why in skipped.items()]


def datahistory(table: TopicTable, calls: TopicTable | None = None) -> np.ndarray:
    """The original Create simulator's saved data: a cell array, one row per pose, of {time since
    the start (s), x (m), y (m), angle from +x (rad), the toolbox calls made since the row began}.

    As in the original, the calls column holds ``[]`` (none), the call's text (one) or a column
    cell of texts (several). ``calls`` is the bridge's ``matlab_calls``: a call belongs to the
    last pose recorded before it (the poses and calls were recorded by the same recorder, so
    their recording times are in step; a call before the first pose goes to the first row).
    """
    rows = np.empty((len(table.t), 5), dtype=object)
    start = table.t[0]
    x, y, theta = (table.columns[k] for k in ("x", "y", "theta"))
    made: list[list[str]] = [[] for _ in table.t]
    if calls is not None:
        for text, when in zip(calls.strings.get("data", []), calls.t_recorded, strict=False):
            made[max(bisect.bisect_right(table.t_recorded, when) - 1, 0)].append(str(text))
    for i, t in enumerate(table.t):
        rows[i] = (t - start, x[i], y[i], theta[i], _calls_cell(made[i]))
    return rows


def _calls_cell(texts: list[str]) -> Any:
    if not texts:
        return np.zeros((0, 0))
    if len(texts) == 1:
        return texts[0]
    cells = np.empty((len(texts), 1), dtype=object)
    cells[:, 0] = texts
    return cells


def bag_to_mat(bag_path: str | Path, output: str | Path | None = None, topics: Iterable[str] | None = None) -> Path:
    """Write ``bag_path`` (folder or .mcap) as a .mat file; returns its path (default: beside the
    bag, ``<bag>.mat``). Topics whose messages cannot be read are left out with a line on stderr."""
    from scipy.io import savemat

    tables, skipped = read_tables(bag_path, topics)
    for line in skipped:
        print(f"bag_to_mat: left out {line}", file=sys.stderr)
    data: dict[str, Any] = {}
    taken = {"topics", "datahistory"}
    listing = np.empty((len(tables), 3), dtype=object)
    for i, table in enumerate(tables):
        name = mat_name(table.topic, taken)
        data[name] = table.struct()
        listing[i] = (name, table.topic, table.type)
    data["topics"] = listing
    ground_truth = [t for t in tables if t.topic.rpartition("/")[2] == OVERHEAD_POSE_TOPIC]
    if len(ground_truth) == 1:
        namespace = ground_truth[0].topic.rpartition("/")[0]
        calls = next((t for t in tables if t.topic == f"{namespace}/matlab_calls"), None)
        data["datahistory"] = datahistory(ground_truth[0], calls)
    path = Path(bag_path)
    out = Path(output) if output else path.parent / f"{path.stem if path.suffix == '.mcap' else path.name}.mat"
    try:
        savemat(out, data, long_field_names=True, do_compression=True, oned_as="column")
    except OSError as err:
        raise InputError(f"{out}: cannot write the .mat file ({err.strerror or err})") from None
    return out


def main(args: list[str] | None = None) -> None:
    """Entry point ``bag_to_mat``."""
    parser = argparse.ArgumentParser(
        prog="bag_to_mat", description="Write a bag (folder or .mcap) as a .mat file for MATLAB/Octave: load(...)"
    )
    parser.add_argument("bag", help="bag folder or .mcap file")
    parser.add_argument("-o", "--output", help="output .mat (default: <bag>.mat beside the bag)")
    parser.add_argument("--topics", nargs="+", metavar="TOPIC", help="only these topics (default: all)")
    opts = parser.parse_args(args)
    try:
        out = bag_to_mat(opts.bag, opts.output, opts.topics)
    except InputError as err:
        print(f"bag_to_mat: error: {err}", file=sys.stderr)
        raise SystemExit(2) from err
    print(f"wrote {out}\nin MATLAB/Octave:  d = load('{out}');")


if __name__ == "__main__":
    main()
