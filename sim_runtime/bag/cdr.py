"""Robot positions read straight from recorded CDR bytes: a whole track without deserialising each message.

Deserialising a PoseStamped with rclpy costs ~30 µs; a 10-minute run has 30,000 of them. Only x and
y are needed to draw a track, and their place in the bytes follows from the strings before them, so
:func:`track_positions` reads them for every message in one numba pass. Layout (little-endian CDR,
offsets from the end of the 4-byte encapsulation header, each field aligned to its size):
``header.stamp`` (8 bytes), ``header.frame_id`` (u32 length with NUL, then the characters), for
Odometry ``child_frame_id`` (a string again), then the pose: position x, y, z as float64.
"""

from __future__ import annotations

from collections.abc import Sequence

import numba
import numpy as np

STRINGS_BEFORE_POSE = {"geometry_msgs/msg/PoseStamped": 1, "nav_msgs/msg/Odometry": 2}
"""Message types whose position this module reads: strings between the stamp and the pose."""


@numba.njit(cache=True)
def _positions(data: np.ndarray, starts: np.ndarray, ends: np.ndarray, strings_before: int) -> np.ndarray:
    """(n, 2) x, y of the messages ``data[starts[i]:ends[i]]``; NaN where a message is too short or
    not little-endian CDR."""
    out = np.full((len(starts), 2), np.nan)
    for i in range(len(starts)):
        origin = starts[i] + 4  # CDR alignment counts from after the encapsulation header
        end = ends[i]
        if end - starts[i] < 4 or data[starts[i]] != 0 or data[starts[i] + 1] != 1:
            continue
        pos = 8  # header.stamp: sec, nanosec
        fits = True
        for _ in range(strings_before):
            pos = (pos + 3) & ~3
            if origin + pos + 4 > end:
                fits = False
                break
            length = 0
            for k in range(4):
                length |= np.int64(data[origin + pos + k]) << (8 * k)
            pos += 4 + length
        pos = (pos + 7) & ~7
        if not fits or origin + pos + 16 > end:
            continue
        out[i, 0] = data[origin + pos : origin + pos + 8].view(np.float64)[0]
        out[i, 1] = data[origin + pos + 8 : origin + pos + 16].view(np.float64)[0]
    return out


def track_positions(type_name: str, messages: Sequence[bytes]) -> np.ndarray | None:
    """x, y (n, 2) of recorded PoseStamped or Odometry messages (CDR bytes); None for other types.

    Rows of messages that cannot be read this way (cut short, big-endian) are NaN."""
    strings = STRINGS_BEFORE_POSE.get(type_name)
    if strings is None:
        return None
    lengths = np.fromiter((len(m) for m in messages), dtype=np.int64, count=len(messages))
    ends = np.cumsum(lengths)
    data = np.frombuffer(b"".join(messages), dtype=np.uint8)
    return _positions(data, ends - lengths, ends, strings)
