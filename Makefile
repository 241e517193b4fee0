# Every target sets up .venv itself (python3 -m venv + pip install -e .[test]) when it is
# missing or pyproject.toml changed, and renders off-screen through EGL (Mesa on CPU works).
SHELL := /bin/bash
export MUJOCO_GL ?= egl
export PYOPENGL_PLATFORM ?= egl
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.sortsim-installed

.PHONY: run test test-all bench soak lint typecheck format venv clean

$(STAMP): pyproject.toml
	@test -x $(PY) || python3 -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[test]'
	@touch $(STAMP)

venv: $(STAMP)

run: $(STAMP)
	$(VENV)/bin/sortsim run --out runs/latest --video runs/latest/video.mp4

test: $(STAMP)
	$(PY) -m pytest -q -m "not slow" -n 2 --dist loadfile

test-all: $(STAMP)
	$(PY) -m pytest -q -n 2 --dist loadfile

# The benchmark scripts, then today's code timed beside BENCH_AGAINST (the speed issue's
# reference commit) in the same run: `sortsim bench --against COMMIT`.
BENCH_AGAINST ?= ef30036
bench: $(STAMP)
	$(VENV)/bin/sortsim bench --against $(BENCH_AGAINST)

# 200 random single-cell episodes and 200 random lines (2-4 robots, 100-400 items), each
# checked: counts add up, no MuJoCo warning, finite state, nothing thrown off the belt
# (benchmarks/soak.py; --episodes, --workers, --seed, --lines).
soak: $(STAMP)
	$(PY) benchmarks/soak.py
	$(PY) benchmarks/soak.py --lines

lint: $(STAMP)
	$(VENV)/bin/ruff check .
	$(VENV)/bin/ruff format --check .

# mypy over sim/, planner/ and perception/ as configured in pyproject.toml ([tool.mypy]).
typecheck: $(STAMP)
	$(VENV)/bin/mypy

format: $(STAMP)
	$(VENV)/bin/ruff check --fix .
	$(VENV)/bin/ruff format .

clean:
	rm -rf $(VENV) runs .pytest_cache
