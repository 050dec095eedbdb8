# One-command set-up: every target creates .venv and installs the project from its own files.
PYTHON ?= python3
VENV ?= .venv
BIN := $(VENV)/bin

.PHONY: install test demo bench lint clean

$(VENV)/.installed: pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e ".[dev]"
	touch $@

install: $(VENV)/.installed

lint: install
	$(BIN)/ruff check .
	$(BIN)/mypy
	$(BIN)/python tools/check_imports.py

test: install lint
	$(BIN)/python -m pytest -q
	$(BIN)/jethr1 batch configs/*.yaml -o out/ci-batch --no-progress

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
	$(BIN)/python bench/bench_replay.py -j 2
	$(BIN)/python bench/bench_stepwise.py -j 2
	$(BIN)/python bench/bench_commands.py

clean:
	rm -rf $(VENV) out .pytest_cache
