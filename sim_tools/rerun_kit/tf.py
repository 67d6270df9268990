"""TF for the views: the transforms of a bag's ``/tf`` and ``/tf_static``, read without tf2_msgs.

``tf2_msgs`` is not on PyPI, so a machine may hold bags with TF that it cannot deserialise through
rclpy. :func:`decode_tf_message` reads a ``tf2_msgs/msg/TFMessage`` straight from its CDR bytes
(the message is a plain list of ``geometry_msgs/TransformStamped``) into objects with the same
attribute names as the rclpy message, so the views draw TF the same way with or without the
package.
"""

from __future__ import annotations

import math
import struct
from types import SimpleNamespace
from typing import NamedTuple

TF_MESSAGE_TYPE = "tf2_msgs/msg/TFMessage"


class Mount(NamedTuple):
    """A frame's planar pose on its parent (the views are top-down): metres and radians."""

    x_m: float
    y_m: float
    yaw_rad: float


class _Cdr:
    """Sequential reader of one CDR (XCDR1) buffer: alignment counts from after the 4-byte header."""

    def __init__(self, data: bytes) -> None:
        if len(data) < 4:
            raise ValueError(f"CDR buffer of {len(data)} bytes has no encapsulation header")
        self.data = data
        self.order = "<" if data[1] & 1 else ">"
        self.pos = 4

    def _align(self, size: int) -> None:
        self.pos += -(self.pos - 4) % size

    def read(self, fmt: str, size: int, align: int) -> tuple:
        self._align(align)
        if self.pos + size > len(self.data):
            raise ValueError(f"CDR buffer ends at byte {len(self.data)}, needed {self.pos + size}")
        values = struct.unpack_from(self.order + fmt, self.data, self.pos)
        self.pos += size
        return values

    def string(self) -> str:
        (length,) = self.read("I", 4, 4)
        if self.pos + length > len(self.data):
            raise ValueError(f"CDR string of {length} bytes runs past the end of the buffer")
        text = self.data[self.pos : self.pos + length].split(b"\0", 1)[0].decode("utf-8", "replace")
        self.pos += length
        return text


def decode_tf_message(data: bytes) -> SimpleNamespace:
    """A TFMessage from its CDR bytes, shaped like the rclpy message (``.transforms[i].header…``).

    Raises ValueError if the bytes are not a TFMessage.
    """
    cdr = _Cdr(data)
    (count,) = cdr.read("I", 4, 4)
    if count > len(data):
        raise ValueError(f"TFMessage claims {count} transforms in {len(data)} bytes")
    transforms = []
    for _ in range(count):
        sec, nanosec = cdr.read("iI", 8, 4)
        frame_id = cdr.string()
        child = cdr.string()
        tx, ty, tz = cdr.read("3d", 24, 8)
        qx, qy, qz, qw = cdr.read("4d", 32, 8)
        transforms.append(
            SimpleNamespace(
                header=SimpleNamespace(stamp=SimpleNamespace(sec=sec, nanosec=nanosec), frame_id=frame_id),
                child_frame_id=child,
                transform=SimpleNamespace(
                    translation=SimpleNamespace(x=tx, y=ty, z=tz),
                    rotation=SimpleNamespace(x=qx, y=qy, z=qz, w=qw),
                ),
            )
        )
    return SimpleNamespace(transforms=transforms)


def planar(transform) -> Mount:
    """The top-down part of a geometry_msgs/Transform: x, y and the rotation about z."""
    t, q = transform.translation, transform.rotation
    yaw = math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))
    return Mount(float(t.x), float(t.y), yaw)


class FrameTree:
    """The latest transform of every child frame, static and moving, from TFMessages."""

    def __init__(self) -> None:
        self.parents: dict[str, tuple[str, Mount]] = {}
        self.static: set[str] = set()

    def add(self, msg, static: bool) -> list[tuple[str, str, Mount]]:
        """Take a TFMessage; returns the (parent, child, mount) it held, frame names without '/'."""
        out = []
        for t in msg.transforms:
            parent, child = t.header.frame_id.strip("/"), t.child_frame_id.strip("/")
            if not parent or not child:
                continue
            mount = planar(t.transform)
            self.parents[child] = (parent, mount)
            if static:
                self.static.add(child)
            out.append((parent, child, mount))
        return out

    def mount_on(self, frame: str, parent_leaf: str = "base_link") -> Mount | None:
        """``frame``'s pose on its parent if that parent's name ends in ``parent_leaf``."""
        entry = self.parents.get(frame.strip("/"))
        if entry is None or entry[0].rpartition("/")[2] != parent_leaf:
            return None
        return entry[1]
