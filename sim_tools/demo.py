"""``make demo``: each simulator's demo, recorded into a bag, converted for the Rerun viewer.

The demos are the registered simulators' (their adapter's ``demo``, :mod:`sim_tools.adapters.contract`):

1. Create world + ``create_bump_turn`` for 60 simulated seconds, as fast as the CPU allows;
2. SIMROBOT: the original's four robots avoiding obstacles and each other, and a fifth that never
   turns and crashes into a wall, 300 lockstep steps, plus the tracks PNG;
3. the IRB120 arm following a joint trajectory, then a target pose.

Every demo runs in one process with a recorder node on the same executor, so nothing is
dropped however fast the world runs. Output goes to ``out/demo/<time>/``.
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path

import rclpy.logging
from rclpy.context import Context
from rclpy.logging import LoggingSeverity
from rclpy.node import Node

from sim_runtime.bag.record import Recorder
from sim_runtime.bag.writer import BagWriter
from sim_tools.adapters.contract import world_parts
from sim_tools.rerun_view.convert import bag_to_rerun


class _Recording:
    """A recorder-node factory for a demo's ``extra_nodes`` hook, closed after the demo."""

    def __init__(self, folder: Path) -> None:
        self.folder = folder
        self.recorder: Recorder | None = None

    def __call__(self, context: Context) -> Sequence[Node]:
        rclpy.logging.set_logger_level("recorder", LoggingSeverity.WARN)  # not one line per topic
        self.recorder = Recorder(BagWriter(self.folder), clock="sim", context=context)
        return [self.recorder]

    def close(self) -> int:
        """Finish the bag; returns the number of messages written."""
        assert self.recorder is not None, "the demo never created its recorder"
        self.recorder.close()
        if self.recorder.error is not None:
            raise RuntimeError(f"recording {self.folder} failed: {self.recorder.error}")
        return self.recorder.writer.message_count


def _recorded(name: str, out: Path, run: Callable[[_Recording], dict]) -> dict:
    recording = _Recording(out / f"{name}_bag")
    summary = run(recording)
    messages = recording.close()
    with warnings.catch_warnings():
        # Command topics (cmd_vel, joint_trajectory) have nothing to draw; that is expected here.
        warnings.filterwarnings("ignore", message=".*is not drawn; skipped")
        rrd = bag_to_rerun(recording.folder, out / f"{name}.rrd", progress=False)
    print(f"  {name}: {messages} messages recorded in {recording.folder}; Rerun file {rrd}")
    return {"summary": summary, "bag": recording.folder, "rrd": rrd}


def demos() -> dict[str, Callable[[Path], dict]]:
    """Every registered simulator's demo by its name: ``demo(out)`` records it and converts the bag."""
    found: dict[str, Callable[[Path], dict]] = {}
    for name, part in world_parts().items():
        if part.demo is not None:
            found[name] = _recorded_demo(name, part.demo)
    return found


def _recorded_demo(name: str, run_demo: Callable[[Path, _Recording], dict]) -> Callable[[Path], dict]:
    def demo(out: Path) -> dict:
        return _recorded(name, out, lambda recording: run_demo(out, recording))

    demo.__doc__ = run_demo.__doc__
    return demo


def main(argv: list[str] | None = None) -> int:
    """Run the demos named on the command line (default all) and print how to view them."""
    available = demos()
    parser = argparse.ArgumentParser(prog="python -m sim_tools.demo", description=__doc__.splitlines()[0])
    parser.add_argument("demos", nargs="*", choices=[*available, []], help="which demos (default: all)")
    parser.add_argument("-o", "--out", default="out/demo", help="parent folder of the run's output")
    options = parser.parse_args(argv)
    out = Path(options.out) / time.strftime("%Y%m%d-%H%M%S")
    out.mkdir(parents=True, exist_ok=False)
    results = {}
    for name in options.demos or list(available):
        print(f"== {name} demo")
        results[name] = available[name](out)
    print("\nOpen a recording in the Rerun viewer (to opt out of the viewer's usage analytics first, see")
    print("the README, 'Recording, replaying and viewing a run'):")
    for result in results.values():
        print(f"  rerun {result['rrd']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
