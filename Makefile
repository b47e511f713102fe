# The two set-up commands of the README: `make demo` (the main job) and
# `make test` (the test suite). Each builds .venv on first use.
PYTHON ?= python3.11
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

export ROS_LOG_DIR ?= $(CURDIR)/.ros_log

.PHONY: demo test test-long bench venv bytecode clean

venv: $(STAMP)

# The pinned requirements go in with uv (itself pinned, installed by pip into the venv first): it fetches and
# unpacks in parallel where pip does one wheel after another (the requirements into a fresh venv on 2 cores, cold
# caches: pip 30 s, uv 5 s). `make INSTALL=pip` installs them with pip alone, for a machine whose pip configuration (an
# index, a proxy) uv does not read. The package itself goes in with pip (editable, as colcon and the tests expect).
# pip compiles what it installs on one core; compileall does the same on every core: the same bytecode, ≈ 10 s less
# of a fresh build on 2 cores (two pairs, back to back: 43 → 33 s and 54 → 44 s). Every process of the suite
# imports from these files: bytecode that is there is not compiled again.
UV_VERSION := 0.13.9
INSTALL ?= uv
ifeq ($(INSTALL),pip)
REQUIREMENTS := $(BIN)/python -m pip install --quiet --no-compile
else
REQUIREMENTS := $(BIN)/uv pip install --quiet --python $(BIN)/python
endif

$(STAMP): requirements.txt requirements-basilisk.txt setup.py setup.cfg package.xml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(if $(filter pip,$(INSTALL)),,$(BIN)/python -m pip install --quiet uv==$(UV_VERSION))
	$(REQUIREMENTS) -r requirements.txt
	$(REQUIREMENTS) --no-deps -r requirements-basilisk.txt
	$(BIN)/python -m pip install --quiet --no-deps --no-build-isolation -e .
	$(BIN)/python -m compileall -q -j 0 $(VENV)/lib
	touch $(STAMP)

# Where PYTHONDONTWRITEBYTECODE is set (it is on the machines this suite is timed on), nothing writes the
# package's bytecode: every process would compile the modules it imports again (≈ 0.1 s of CPU each).
# Compiled here, at once, only what changed.
bytecode: $(STAMP)
	$(BIN)/python -m compileall -q pmv_ros pmv_msgs_shim tests

demo: $(STAMP) bytecode
	$(BIN)/pmv simulate --config config/kondor.yaml --orbits 1 --report report

# One BLAS thread in every process of the suite: the workers and their children already fill the two cores, and
# a BLAS thread waiting for work spins. The parallel part, back to back on one machine: 319 s (560 s of CPU) with
# the default threads, 277 s (479 s) with one. The campaign's Dask workers are set the same way (WORKER_ENVIRONMENT,
# pmv_ros/apps/campaign/cluster.py).
test test-long: export OPENBLAS_NUM_THREADS = 1
test test-long: export OMP_NUM_THREADS = 1
test test-long: export MKL_NUM_THREADS = 1

# Three workers on two cores: much of the suite waits on child processes, discovery and simulated time; with three
# the cores still stood idle 8 % of the parallel part (back to back on one machine: two workers 408 s, three 347 s).
# xdist hands out groups (--dist loadgroup): a test module is a group (its module fixtures run once), and the
# modules that share a session fixture declare one group in their pytestmark; the groups go out in the order
# tests/conftest.py sorts them (--no-loadscope-reorder keeps it). Tests whose figures are rates of wall time
# (marked serial) run afterwards, alone.
test: $(STAMP) bytecode
	$(BIN)/python -m pytest -q -n 3 --dist loadgroup --no-loadscope-reorder -m "not serial"
	$(BIN)/python -m pytest -q -m serial

# Tests marked `long` at full length: the 24 h soak (≈ 20 min) and 60 s of 50 Hz load; figures printed.
test-long: $(STAMP)
	$(BIN)/python -m pytest -q -m long --run-long

# Every benchmarks/bench_*.py, each with its own printout, then one table of their headlines (benchmarks/README.md).
bench: $(STAMP)
	$(BIN)/python benchmarks/run.py

# The documentation (docs/, the Sphinx project rosdoc2 builds too) into docs/_build/html: warnings are errors,
# every reference must resolve (-n), and every page is read afresh (-E) so the parameter reference is current.
.PHONY: docs
docs: $(STAMP)
	$(BIN)/python -m sphinx -W --keep-going -n -E -q -b html docs docs/_build/html

clean:
	rm -rf $(VENV) build install log .ros_log report *.egg-info
