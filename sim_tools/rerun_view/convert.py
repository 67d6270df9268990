"""``bag_to_rerun BAG [-o OUT.rrd]``: a bag drawn as a Rerun recording on the sim-time timeline.

Every message goes through :class:`~sim_tools.rerun_view.logger.RerunLogger` (the same drawing
as the live ``rerun`` view). Topics of types it does not draw, or whose message package is not
installed, are skipped with a warning. Writes the ``.rrd`` (no viewer is started) and prints the
command that opens it.
"""

from __future__ import annotations

import argparse
import gc
import sys
import time
import warnings
from pathlib import Path
from typing import TextIO

import rerun as rr

from sim_runtime.bag.reader import UnknownMessageType, open_bag
from sim_runtime.errors import InputError
from sim_tools.rerun_kit.tf import TF_MESSAGE_TYPE, decode_tf_message
from sim_tools.rerun_view.logger import RerunLogger, quiet_topics, supported_types

APPLICATION_ID = "robot_sims"
ROS_INTERNAL_TOPICS = frozenset({"/parameter_events", "/rosout"})
"""Skipped without a warning: every node publishes them, nothing to draw."""
QUIET_TOPIC_NAMES = frozenset({"robot_description"})
"""Last name segments skipped without a warning: a world's URDF (the views draw its links from the
world's markers and transforms); the simulators' drawings name theirs (``quiet_topics``)."""


class Progress:
    """A one-line progress bar on a stream (stderr), redrawn at most ten times a second."""

    def __init__(self, total: int, label: str, stream: TextIO | None = None) -> None:
        self.total = max(total, 1)
        self.label = label
        self.stream = sys.stderr if stream is None else stream
        self._last = 0.0
        self._last_decile = -1
        self._tty = self.stream.isatty()

    def update(self, done: int, force: bool = False) -> None:
        frac = min(done / self.total, 1.0)
        if self._tty:
            now = time.monotonic()
            if not force and now - self._last < 0.1:
                return
            self._last = now
            end = "\r"
        else:  # a log file gets a line per 10 %, not a redraw per tenth of a second
            decile = int(10 * frac)
            if decile == self._last_decile and not force:
                return
            self._last_decile = decile
            end = "\n"
        bar = "#" * int(30 * frac)
        text = f"{self.label} [{bar:<30}] {100 * frac:5.1f}% {done}/{self.total} messages"
        self.stream.write(f"\r{text}" if self._tty else f"{text}{end}")
        self.stream.flush()

    def close(self, done: int) -> None:
        self.update(done, force=not self._tty or done < self.total)
        if self._tty:
            self.stream.write("\n")
        self.stream.flush()


def default_output(bag_path: str | Path) -> Path:
    """``<bag>.rrd`` beside the bag folder (or beside the .mcap file)."""
    path = Path(bag_path).resolve()
    return path.with_suffix(".rrd") if path.suffix == ".mcap" else path.with_name(path.name + ".rrd")


def bag_to_rerun(bag_path: str | Path, out: str | Path | None = None, *, progress: bool = True) -> Path:
    """Convert a bag (folder or .mcap) into a Rerun ``.rrd`` file; returns its path.

    Raises InputError if the bag cannot be opened or the output cannot be written.
    """
    bag = open_bag(bag_path)
    if bag.message_count == 0:
        raise InputError.at(bag.path, None, "no readable messages (empty, or not an MCAP bag)")
    out_path = Path(out) if out is not None else default_output(bag_path)
    if out_path.is_dir():
        raise InputError(f"output {out_path}: is a folder; give a file name ending in .rrd")
    if not out_path.parent.is_dir():
        raise InputError(f"output {out_path}: folder {out_path.parent} does not exist")
    drawn = supported_types()
    skipped = {t: kind for t, kind in bag.topics.items() if kind not in drawn}
    quiet = QUIET_TOPIC_NAMES | quiet_topics()
    for topic, kind in sorted(skipped.items()):
        if topic in ROS_INTERNAL_TOPICS or topic.rsplit("/", 1)[-1] in quiet:
            continue
        warnings.warn(f"{bag.path}: topic {topic} of type {kind or '(no schema)'} is not drawn; skipped", stacklevel=2)
    wanted = [t for t in bag.topics if t not in skipped]

    rec = rr.RecordingStream(APPLICATION_ID, recording_id=None)
    rec.set_log_time_enabled(False)  # wall-clock at conversion time means nothing: sim_time only
    logger = RerunLogger(rec, {t: bag.topics[t] for t in wanted}, batch_scalars=True)
    rec.save(out_path)
    rec.send_recording_name(Path(bag.path).name)

    bar = (
        Progress(sum(bag.topic_counts.get(t, 0) for t in wanted), f"bag_to_rerun {Path(bag.path).name}")
        if progress
        else None
    )
    done = 0
    try:
        for m in bag.messages(topics=wanted):
            try:
                msg = m.msg
            except UnknownMessageType as err:
                if m.type == TF_MESSAGE_TYPE:  # tf2_msgs is not installed: read the CDR directly
                    try:
                        logger.log(m.topic, decode_tf_message(m.data), m.log_time_ns, TF_MESSAGE_TYPE)
                        done += 1
                    except ValueError as bad:
                        warnings.warn(f"{bag.path}: topic {m.topic}: {bad}; message skipped", stacklevel=2)
                    continue
                warnings.warn(f"{bag.path}: {err}; topic {m.topic} skipped", stacklevel=2)
                wanted.remove(m.topic)
                skipped[m.topic] = m.type
                continue
            except Exception as err:
                warnings.warn(
                    f"{bag.path}: topic {m.topic} at log time {m.log_time_ns} ns: cannot "
                    f"deserialise {m.type} ({err}); message skipped",
                    stacklevel=2,
                )
                continue
            if m.topic in skipped:
                continue
            logger.log(m.topic, msg, m.log_time_ns)
            done += 1
            if bar is not None:
                bar.update(done)
    finally:
        if bar is not None:
            bar.close(done)
        logger.flush()
        # Sent last: the plot views depend on what the bag held.
        rec.send_blueprint(logger.blueprint(), make_active=True, make_default=True)
        rec.flush()
        rec.disconnect()
        del logger, rec
        _release_finished_recordings()
    return out_path


def _release_finished_recordings() -> None:
    """Stop the threads of recordings nothing refers to any more. Rerun keeps a dropped recording's
    batcher and sink threads (and ~1 MB) until such a sweep, so a long-lived process (the studio, a
    fuzz worker) would grow by that for every conversion. What remains per conversion is the
    blueprint recording ``send_blueprint`` makes (rerun-sdk 0.41 never releases it: 2 threads)."""
    gc.collect()  # a recording in a reference cycle is only dropped by the collector
    rr.bindings.flush_and_cleanup_orphaned_recordings()


def main(args: list[str] | None = None) -> None:
    """Entry point ``bag_to_rerun``."""
    parser = argparse.ArgumentParser(
        prog="bag_to_rerun", description="Convert a bag (folder or .mcap) into a Rerun .rrd recording."
    )
    parser.add_argument("bag", help="bag folder or .mcap file")
    parser.add_argument("-o", "--output", help="output .rrd (default: <bag>.rrd beside the bag)")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar on stderr")
    opts = parser.parse_args(args)
    try:
        out = bag_to_rerun(opts.bag, opts.output, progress=not opts.no_progress)
    except InputError as err:
        print(f"bag_to_rerun: error: {err}", file=sys.stderr)
        raise SystemExit(2) from err
    print(f"wrote {out}\nopen it with:\n  rerun {out}")


if __name__ == "__main__":
    main()
