# gfxlab: the two commands.
#   make lab   - create .venv if missing, install gfxlab, open JupyterLab on labs/
#   make test  - create .venv if missing, install gfxlab[dev], run every test and notebook
#   make bench - run the benchmarks in tests/benchmarks (not part of make test)

PYTHON ?= $(shell command -v python3.11 2>/dev/null || command -v python3)
VENV := .venv
BIN := $(VENV)/bin
# Parallel test workers: 2 on CI-sized machines; override with `make test WORKERS=1`.
WORKERS ?= 2

.PHONY: lab test bench lint clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

# Reinstall whenever pyproject.toml changes.
$(VENV)/.installed: pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet -e .
	touch $@

$(VENV)/.installed-dev: pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet -e '.[dev]'
	touch $(VENV)/.installed $@

# Jupyter refuses to run as root unless told to (containers, CI machines).
ROOT_FLAG := $(if $(filter 0,$(shell id -u)),--allow-root,)

lab: $(VENV)/.installed
	$(BIN)/jupyter lab --notebook-dir=labs $(ROOT_FLAG) $(LAB_ARGS)

# pytest exits 5 when it collects nothing; that is not a failure of the suite.
test: $(VENV)/.installed-dev
	@MPLBACKEND=Agg $(BIN)/python -m pytest -n $(WORKERS) --dist loadgroup --nbmake \
		tests labs/[0-9]*.ipynb; rc=$$?; \
	if [ $$rc -eq 5 ]; then echo "no tests collected"; exit 0; fi; exit $$rc

bench: $(VENV)/.installed-dev
	MPLBACKEND=Agg $(BIN)/python tests/benchmarks/run.py $(BENCH)

lint: $(VENV)/.installed-dev
	$(BIN)/ruff check gfxlab tests labs

clean:
	rm -rf $(VENV) build *.egg-info .pytest_cache
