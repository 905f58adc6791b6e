# The two commands of the README: `make demo` and `make test` (which runs `make lint` first).
# Each creates its own virtual environment (.venv) from nothing but python3.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: warm demo lint test test-ursim bench clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[screen,test,bench]'
	touch $(STAMP)

# The kinematics kernels compile once into numba's cache (about half a minute after an install), before anything
# else starts: the demo's processes and the test workers then load them instead of each compiling its own.
warm: $(STAMP)
	$(BIN)/python -m ur3dq.kinematics.jit --warm

demo: warm
	$(BIN)/ur3dq demo

# ruff (pycodestyle, pyflakes, isort, bugbear, pyupgrade) and mypy, both configured in pyproject.toml.
lint: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/mypy

# Lint and the kernels' compilation side by side (each keeps one core busy for a quarter of a minute), then two
# passes: the suite on four workers (it mostly waits on simulated motion), then the timing measurements alone
# (marker `exclusive`).
test: $(STAMP)
	$(MAKE) --no-print-directory -j2 lint warm
	$(BIN)/python -m pytest -m "not exclusive"
	$(BIN)/python -m pytest -m exclusive -n 0

# The same suite against an official URSim or robot: UR3DQ_TEST_HOST=<address> make test-ursim (docs/ursim.md).
test-ursim: warm
	@test -n "$(UR3DQ_TEST_HOST)" || { echo "test-ursim: set UR3DQ_TEST_HOST to the URSim's address" >&2; exit 2; }
	UR3DQ_TEST_HOST=$(UR3DQ_TEST_HOST) $(BIN)/python -m pytest -m "not exclusive"

bench: warm
	$(BIN)/python benchmarks/bench_kinematics.py
	$(BIN)/python benchmarks/bench_pathcheck.py
	$(BIN)/python benchmarks/bench_dls.py
	$(BIN)/python benchmarks/bench_driver.py
	$(BIN)/python benchmarks/bench_rtde_stream.py
	$(BIN)/python benchmarks/bench_screen.py

clean:
	rm -rf $(VENV) .pytest_cache .hypothesis
