# `make test` and `make demo` each set up .venv on first use (one pip install), then run.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.robot_sims-installed

# DDS stays on this machine; fast discovery for multi-process runs; ament_index finds the venv.
export ROS_AUTOMATIC_DISCOVERY_RANGE := LOCALHOST
export FASTRTPS_DEFAULT_PROFILES_FILE := $(CURDIR)/config/fastdds_localhost.xml
export AMENT_PREFIX_PATH := $(CURDIR)/$(VENV)

.PHONY: venv test demo bench lint clean

venv: $(STAMP)

$(STAMP): setup.py interfaces/build_tf2_msgs.py interfaces/tf2_msgs/pyproject.toml
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) interfaces/build_tf2_msgs.py
	$(PY) -m pip install --quiet -e '.[test]'
	$(PY) -m sim_runtime.warmup
	touch $@

lint: venv
	$(PY) -m ruff check . && $(PY) -m ruff format --check .

test: venv lint
	$(PY) -m pytest -q

demo: venv
	$(PY) -m sim_runtime.demo

bench: venv
	$(PY) -m pip install --quiet -e '.[test,bench]' || echo "roboticstoolbox-python unavailable: bench/arm.py skips its columns"
	set -e; for script in bench/*.py; do echo "== $$script"; $(PY) $$script; done

clean:
	rm -rf build *.egg-info out
