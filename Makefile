# `make test` and `make demo` each set up .venv on first use (one pip install), then run.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.robot_sims-installed

# DDS stays on this machine; fast discovery for multi-process runs; ament_index finds the venv.
export ROS_AUTOMATIC_DISCOVERY_RANGE := LOCALHOST
export FASTRTPS_DEFAULT_PROFILES_FILE := $(CURDIR)/config/fastdds_localhost.xml
export AMENT_PREFIX_PATH := $(CURDIR)/$(VENV)

.PHONY: venv test test-long test-random demo screenshots bench lint clean fuzz soak test-boundscheck architecture test-sb3

venv: $(STAMP)

$(STAMP): setup.py interfaces/build_interfaces.py interfaces/cmake/pip_prefix.cmake \
	  interfaces/tf2_msgs/pyproject.toml interfaces/robot_sims_interfaces/pyproject.toml \
	  interfaces/robot_sims_interfaces/srv/SetPose.srv
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[test]'
	# After the project: the interfaces' build finds the ROS wheels (fastrtps_cmake_module, ...) in the venv.
	$(PY) interfaces/build_interfaces.py
	$(PY) -m sim_tools.warmup
	touch $@

lint: venv
	$(PY) -m ruff check . && $(PY) -m ruff format --check . && $(PY) -m mypy && $(VENV)/bin/lint-imports

# The suite on $(TEST_WORKERS) pytest-xdist workers, each in a ROS domain of its own (test/conftest.py:
# the caller's ROS_DOMAIN_ID plus the worker's number). One worker per core: with 4 on 2 cores a
# fresh clone's run held the load at 8-20 by itself and 22 real-time comparisons (MATLAB twins,
# browser waits, Ray's start-up) failed; the suite is CPU-bound (numba, Chromium, worlds) more than
# it waits. `--dist loadfile` keeps each file on one worker: a module's expensive fixtures (worlds,
# a studio, a browser) start once, and each studio module keeps its own domain. The `long` tests
# (minutes each) run in `make test-long`.
TEST_WORKERS ?= 2
# The slowest tests are listed at the end of each run, so a slow newcomer is seen in CI's log.
PYTEST_PARALLEL := $(PY) -m pytest -q -p no:randomly -n $(TEST_WORKERS) --dist loadfile --durations=30
test: venv lint
	$(PYTEST_PARALLEL) -m "not long"

# What `make test` leaves out: the tests marked `long` (pyproject.toml); .ci/run runs them too.
test-long: venv
	$(PYTEST_PARALLEL) -m long

# The suite in a random order (pytest-random-order: tests shuffled within each file, files
# shuffled), to find tests that need the ones before them. Opt-in: `make test` keeps the file's
# order. Again with the order printed at the top: `make test-random SEED=<that seed>`.
SEED ?= $(shell od -An -N3 -tu4 /dev/urandom | tr -d ' ')
test-random: venv
	$(PYTEST_PARALLEL) --random-order-bucket=module --random-order-seed=$(SEED) -m "not long"

demo: venv
	$(PY) -m sim_tools.demo

# docs/rerun_*.png from fresh demo runs, taken by a headless Rerun viewer (needs mesa-vulkan-drivers).
screenshots: venv
	$(PY) docs/make_rerun_screenshot.py

# docs/architecture.md's generated parts (contracts, import graph, facts) from the code; test_architecture_doc checks them.
architecture: venv
	$(PY) docs/make_architecture.py

# The sb3 extra (Stable-Baselines3 and torch, CPU) and its test (a tiny PPO run exported and run
# in a batch): out of the test install, torch is large; `make test` skips test_rl_sb3.py without it.
test-sb3: venv
	$(PY) -m pip install --quiet -e '.[sb3]'
	$(PY) -m pytest -q test/test_rl_sb3.py

bench: venv
	$(PY) -m pip install --quiet -e '.[test,bench]' || echo "a baseline (roboticstoolbox-python, ir-sim) unavailable: bench/arm.py and bench/envs.py skip its columns"
	set -e; for script in $(filter-out bench/soak.py bench/_%.py,$(wildcard bench/*.py)); do echo "== $$script"; $(PY) $$script; done

# Mutation fuzzer over every input format (and alias bombs, odd line ends, huge legal files):
# 100,000 inputs or 15 minutes on 2 worker processes, each input held to 20 CPU s and 1 GB;
# defects (with their inputs) under out/fuzz/defects, counts in out/fuzz/summary.json.
fuzz: venv
	$(PY) -m sim_tools.fuzz --inputs 100000 --seconds 900 --workers 2 --budget-cpu-seconds 20 --budget-mb 1024 --out out/fuzz

# Soak: each world for an hour of sim time at real_time_factor 0, recorder on; a cmd_vel flood.
soak: venv
	$(PY) bench/soak.py

# The model and kernel tests (and a fuzz sample) again with numba's bounds checks compiled in,
# so an out-of-range index fails a test instead of corrupting memory. Own numba cache: cached
# kernels compiled without the checks must not be reused.
BOUNDSCHECK_TESTS := test/test_create_model.py test/test_create_files.py test/test_simrobot_model.py \
	test/test_simrobot_raycast.py test/test_simrobot_world_file.py test/test_arm_model.py test/test_arm_inputs.py \
	test/test_yaml_inputs.py test/test_fuzz.py
test-boundscheck: venv
	NUMBA_BOUNDSCHECK=1 NUMBA_CACHE_DIR=$(CURDIR)/out/numba-boundscheck $(PY) -m pytest -q -p no:cacheprovider $(BOUNDSCHECK_TESTS)

clean:
	rm -rf build *.egg-info out
