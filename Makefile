# One-command set-up: every target creates .venv and installs the project from its own files, at the versions
# of the lock (constraints.txt: the tested set, docs/install.md). PYTHON and VENV choose another Python, e.g.
# make test PYTHON=python3.13 VENV=.venv-3.13
PYTHON ?= python3
VENV ?= .venv
BIN := $(VENV)/bin
LOCK := constraints.txt
LATEST := .venv-latest
LOCK_CHECK ?=
BATCH_OUT ?= out/ci-batch

.PHONY: install test demo bench lint clean check-latest lock

$(VENV)/.installed: pyproject.toml $(LOCK)
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip -c $(LOCK)
	$(BIN)/python -m pip install --quiet -c $(LOCK) --build-constraint $(LOCK) -e ".[dev]"
	$(BIN)/python tools/check_lock.py $(LOCK)
	$(BIN)/python -m compileall -q jethr1_plan  # the bytecode written now (an editable install writes none), not in a first command
	$(BIN)/jethr1 warm-up configs/terrains/*.yaml  # the kernels compiled and Paper A's maps computed, ahead of any command
	touch $@

install: $(VENV)/.installed

lint: install
	$(BIN)/ruff check .
	$(BIN)/mypy
	$(BIN)/python tools/check_imports.py
	$(BIN)/python tools/check_size.py
	$(BIN)/python tools/architecture.py --check
	$(BIN)/python tools/check_vocabulary.py

test: install lint
	$(BIN)/python tools/check_lock.py $(LOCK_CHECK) $(LOCK)
	$(BIN)/python -m pytest -q -n auto --dist loadfile  # every core (pytest-xdist); a file's tests in one worker
	rm -rf $(BATCH_OUT)  # (a scratch folder: jethr1 itself never replaces files it has no record of writing)
	$(BIN)/jethr1 batch configs/*.yaml -o $(BATCH_OUT) --no-progress

demo: install
	$(BIN)/jethr1 robot show
	$(BIN)/jethr1 plan configs/jet_hr1_trial_robust.yaml -o out
	$(BIN)/jethr1 simulate out/jet_hr1_trial_robust --controller feedback
	@echo "Foxglove/Lichtblick: open out/jet_hr1_trial_robust/trajectory.mcap and simulation.mcap together, and import the layout"
	@$(BIN)/python -c "from jethr1_plan.cli.plan import LAYOUT; print(LAYOUT)"
	@echo "Rerun (pip install '.[view]'): $(BIN)/jethr1 view out/jet_hr1_trial_robust [--save plan.rrd]"
	@echo "ROS 2: ros2 bag play out/jet_hr1_trial_robust/trajectory.mcap (docs/files_and_viewers.md)"

bench: install
	$(BIN)/python bench/bench_evaluator.py
	$(BIN)/python bench/bench_plan.py
	$(BIN)/python bench/bench_balance_space.py
	$(BIN)/python bench/bench_simulate.py
	$(BIN)/python bench/bench_certificates.py -j 2
	$(BIN)/python bench/bench_walk.py
	$(BIN)/python bench/bench_route.py
	$(BIN)/python bench/bench_replan_steps.py
	$(BIN)/python bench/bench_design.py
	$(BIN)/python bench/bench_replay.py -j 2
	$(BIN)/python bench/bench_stepwise.py -j 2
	$(BIN)/python bench/bench_commands.py
	$(BIN)/python bench/bench_fast_timing.py --trials 40 -j 2

# The newest releases: the project installed unpinned into a fresh $(LATEST), the whole of `make test` run there,
# and how the newest versions differ from the lock. `make lock` then moves the lock to them (docs/install.md).
check-latest:
	rm -rf $(LATEST)
	$(PYTHON) -m venv $(LATEST)
	$(LATEST)/bin/python -m pip install --quiet --upgrade pip
	$(LATEST)/bin/python -m pip install --quiet -e ".[dev]"
	touch $(LATEST)/.installed
	$(MAKE) --no-print-directory test VENV=$(LATEST) LOCK_CHECK=--report BATCH_OUT=out/ci-batch-latest
	touch $(LATEST)/.passed
	@echo "check-latest: the suite passed on the newest releases; against the lock:"
	@$(LATEST)/bin/python tools/check_lock.py --report $(LOCK)

lock: $(LATEST)/.passed
	$(LATEST)/bin/python tools/check_lock.py --write $(LOCK)

$(LATEST)/.passed: pyproject.toml
	@echo "make lock writes the lock from the environment of a passed \`make check-latest\` (after the last change to pyproject.toml): run it first" >&2
	@exit 1

clean:
	rm -rf $(VENV) out .pytest_cache
