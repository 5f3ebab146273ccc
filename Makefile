# manigrasp: the two commands a fresh machine needs are `make bench` and `make test`.
PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin
JOBS   ?= 2
EXTRAS ?= dev
comma  := ,
STAMP  := $(VENV)/.installed-$(subst $(comma),-,$(EXTRAS))

RUN    ?= runs/quick

.PHONY: setup bench test test-fast regression lint clean

setup: $(STAMP)

# A virtual environment with the pinned dependencies (constraints.txt is the lock), then a check that each
# extra works (perception: open3d also needs the system library libusb-1.0: apt-get install libusb-1.0-0).
$(STAMP): pyproject.toml constraints.txt
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --disable-pip-version-check -c constraints.txt -e ".[$(EXTRAS)]"
	$(BIN)/python -m manigrasp.bench.extras $(EXTRAS)
	touch $(STAMP)

# The main job on the embedded defaults: the quick benchmark (resumes if interrupted),
# then its summary table and report.md. Delete $(RUN) for a fresh run.
bench: setup
	$(BIN)/manigrasp bench quick --out $(RUN) --jobs $(JOBS)

# Regression gate: fresh runs of quick (parallel jaw) and regression_dexterous (a five-finger hand) compared
# with their committed baselines; both verdicts are printed, then the worse exit code (1: a significantly lower
# success rate, 2: not comparable), each compare at alpha 0.025 so that the two together fail a run as good as
# its baselines by chance less than 5 % of the time. CI runs it.
regression: setup
	rm -rf runs/regression runs/regression_dexterous
	$(BIN)/manigrasp bench quick --out runs/regression --jobs $(JOBS) --quiet
	$(BIN)/manigrasp bench regression_dexterous --out runs/regression_dexterous --jobs $(JOBS) --quiet
	$(BIN)/manigrasp compare runs/regression benchmarks/baselines/quick.json --alpha 0.025; quick=$$?; \
	$(BIN)/manigrasp compare runs/regression_dexterous benchmarks/baselines/dexterous.json --alpha 0.025; dexterous=$$?; \
	exit $$(( quick > dexterous ? quick : dexterous ))

# The whole suite (what CI runs), on $(JOBS) worker processes (pytest-xdist), each taking whole test files so that
# a file's module fixtures are built once; `$(BIN)/python -m pytest` runs it in one process.
test: setup
	$(BIN)/python -m pytest -n $(JOBS) --dist loadfile

# Everything but the tests marked slow (each over ~1.5 s of CPU: every shipped object built and planned, benchmark
# runs, CoACD builds, worker processes, kill -9, Ray, hard time-outs): about 100 s of CPU.
test-fast: setup
	$(BIN)/python -m pytest -m "not slow" -n $(JOBS) --dist loadfile

lint: setup
	$(BIN)/ruff check manigrasp tests benchmarks

clean:
	rm -rf $(VENV) runs .pytest_cache .ruff_cache build dist *.egg-info
	find . -name __pycache__ -type d -prune -exec rm -rf {} +
