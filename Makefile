# manigrasp: the two commands a fresh machine needs are `make bench` and `make test`.
PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin
JOBS   ?= 2
EXTRAS ?= dev
comma  := ,
STAMP  := $(VENV)/.installed-$(subst $(comma),-,$(EXTRAS))

.PHONY: setup bench test lint clean

setup: $(STAMP)

# A virtual environment with the pinned dependencies (constraints.txt is the lock).
$(STAMP): pyproject.toml constraints.txt
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --disable-pip-version-check -c constraints.txt -e ".[$(EXTRAS)]"
	touch $(STAMP)

# The main job on the embedded defaults.
bench: setup
	$(BIN)/manigrasp objects build --all --jobs $(JOBS)

test: setup
	$(BIN)/python -m pytest

lint: setup
	$(BIN)/ruff check manigrasp tests benchmarks

clean:
	rm -rf $(VENV) runs .pytest_cache .ruff_cache build dist *.egg-info
	find . -name __pycache__ -type d -prune -exec rm -rf {} +
