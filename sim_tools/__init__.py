"""Tools over the simulators: batch sweeps, fuzzing, Rerun views, the demo, the warm-up, the CLI."""
