"""A recorded run carries its frames: every frame_id in the demo bags resolves through the bag's TF."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest

from sim_runtime.bag.reader import open_bag
from sim_tools.demo import _Recording

ROOTS = ("map", "world")


def _frames(msg: Any) -> Iterator[str]:
    """Every frame a message names (headers, nested markers, odometry's child frame)."""
    header = getattr(msg, "header", None)
    if header is not None and header.frame_id:
        yield header.frame_id
    if getattr(msg, "child_frame_id", ""):
        yield msg.child_frame_id
    for marker in getattr(msg, "markers", ()):
        yield from _frames(marker)
    for transform in getattr(msg, "transforms", ()):
        yield from _frames(transform)


def _run(name: str, recording: _Recording, out) -> None:
    if name == "create":
        from create_sim.bump_turn import demo

        demo(5.0, extra_nodes=recording)
    elif name == "simrobot":
        from simrobot_sim.demo import run_demo

        run_demo(out, steps=30, extra_nodes=recording)
    else:
        from arm_sim.demo import run_demo

        run_demo(out, extra_nodes=recording)


@pytest.mark.parametrize("name", ["create", "simrobot", "arm"])
def test_every_frame_in_a_demo_bag_resolves_to_the_map_through_the_bags_tf(name, tmp_path, tf2_msgs):
    recording = _Recording(tmp_path / "bag")
    _run(name, recording, tmp_path)
    recording.close()
    parent: dict[str, str] = {}
    named: set[str] = set()
    for record in open_bag(tmp_path / "bag").messages():
        msg = record.msg
        if record.topic in ("/tf", "/tf_static"):
            for t in msg.transforms:
                parent[t.child_frame_id] = t.header.frame_id
        named.update(_frames(msg))
    assert parent, "the bag has no /tf or /tf_static"

    def root(frame: str) -> str:
        seen = [frame]
        while seen[-1] in parent and len(seen) < 50:
            seen.append(parent[seen[-1]])
        return seen[-1]

    unresolved = sorted(f for f in named if root(f) not in ROOTS)
    assert not unresolved, f"frames not connected to {ROOTS}: {unresolved}"
