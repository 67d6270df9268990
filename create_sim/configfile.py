"""Create config files (sensor noise and communication delay), in the original's format.

Rows ``<sensor> mean std`` for sensor in wall, cliff, odometry, sonar, lidar, camera, and
``com_delay seconds``; ``%`` comments, blank rows and whitespace as in map files; keywords are
case-insensitive. Unlisted sensors are noise-free. ``imu`` rows are accepted and ignored with a
warning (the original accepted them but had no IMU). Unknown rows warn and are skipped, but a file
none of whose rows is known (``/etc/passwd``) is refused; bad values raise :class:`InputError`
naming file, line and value. Warnings go to ``warn`` (a node's logger), or by default to Python's
:mod:`warnings`.

What mean/std mean per sensor (from the original's user manual): wall – offset of the IR range (m);
cliff – added to the signal (%); odometry and camera – proportional (0.02 = 2 %); sonar, lidar –
added to the distance (m).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from create_sim.mapfile import Warn, parse_number, python_warning, read_text_file, report_skipped, split_row
from sim_runtime.errors import InputError

SENSORS = ("wall", "cliff", "odometry", "sonar", "lidar", "camera")


@dataclass
class NoiseConfig:
    """Noise (mean, std) per sensor and the command/reading delay; the default is ideal."""

    noise: dict[str, tuple[float, float]] = field(default_factory=dict)
    com_delay: float = 0.0

    def __post_init__(self) -> None:
        for name in SENSORS:
            self.noise.setdefault(name, (0.0, 0.0))

    def to_text(self) -> str:
        """The config in the file format, numbers written exactly (``parse_config`` gives it back)."""
        rows = ["% SensorName NoiseMean NoiseStandardDev"]
        rows += [f"{name} {self.noise[name][0]!r} {self.noise[name][1]!r}" for name in SENSORS]
        rows += ["", f"com_delay {self.com_delay!r}"]
        return "\n".join(rows) + "\n"


MAX_NOISE = 1e6
"""Largest |mean| or std a noise row may hold."""
MAX_COM_DELAY_S = 3600.0
"""Longest communication delay a config may ask for."""


def parse_config(text: str, source: str = "<string>", warn: Warn | None = None) -> NoiseConfig:
    """Parse config-file text; ``source`` names the file in warnings and errors, ``warn`` receives
    the warnings (default: Python's :mod:`warnings`)."""
    config = NoiseConfig()
    skipped: list[tuple[int, str]] = []
    recognised = 0
    for number, raw in enumerate(text.splitlines(), start=1):
        tokens = split_row(raw)
        if not tokens:
            continue
        keyword = tokens[0].lower()
        args = tokens[1:]
        if keyword in SENSORS or keyword == "imu":
            if len(args) != 2:
                raise InputError.at(
                    source, number, f"'{keyword}' needs 2 numbers (mean std), got {len(args)}: {' '.join(args)!r}"
                )
            mean = parse_number(args[0], f"{keyword} mean", source, number)
            std = parse_number(args[1], f"{keyword} std", source, number)
            if std < 0.0:
                raise InputError.at(source, number, f"{keyword} std {args[1]!r} must be >= 0")
            if max(abs(mean), std) > MAX_NOISE:
                # Noise this size only turns readings into inf (a proportional camera error of 1e300).
                raise InputError.at(source, number, f"{keyword} noise {' '.join(args)!r} beyond ±{MAX_NOISE:g}")
            recognised += 1
            if keyword == "imu":
                (warn or python_warning)(f"{source}:{number}: 'imu' noise ignored (the simulated Create has no IMU)")
                continue
            config.noise[keyword] = (mean, std)
        elif keyword == "com_delay":
            if len(args) != 1:
                raise InputError.at(
                    source, number, f"'com_delay' needs 1 number (seconds), got {len(args)}: {' '.join(args)!r}"
                )
            delay = parse_number(args[0], "com_delay", source, number)
            if not 0.0 <= delay <= MAX_COM_DELAY_S:
                raise InputError.at(source, number, f"com_delay {args[0]!r} must be in 0..{MAX_COM_DELAY_S:g} s")
            config.com_delay = delay
            recognised += 1
        else:
            skipped.append((number, raw.strip()))
    report_skipped(skipped, recognised, source, f"{', '.join(SENSORS)} or com_delay", warn)
    return config


def load_config(path: str | Path, warn: Warn | None = None) -> NoiseConfig:
    """Read and parse a config file (``warn``: as :func:`parse_config`)."""
    return parse_config(read_text_file(path, "config"), str(path), warn)
