# gfxlab: the two commands.
#   make lab   - create .venv if missing, install gfxlab[lab], open JupyterLab on labs/
#   make test  - create .venv if missing, install gfxlab[dev], run every test and notebook,
#                lint, and build the documentation site from the executed labs
#   make bench - run the benchmarks in tests/benchmarks (not part of make test)
#   make docs  - build the documentation site into build/site (make test does it too)

PYTHON ?= $(shell command -v python3.11 2>/dev/null || command -v python3)
VENV := .venv
BIN := $(VENV)/bin
# Parallel test workers: 3 on a 2-core CI machine, because a worker often waits on a
# child process (a lab's kernel, a grading sandbox, pip, the contract sweep) and a third
# keeps both cores busy (measured: 2 workers kept the CPUs 84 % busy, 3 workers 99 %;
# ~1.2 GB each). Override with `make test WORKERS=1`.
WORKERS ?= 3
# Executed labs (written by the lab tests, read by the docs build).
LABS_OUT ?= build/labs

# One persistent JAX compilation cache of the user's for tests, notebooks and the lab
# runner (JAX reads these variables; the grading sandbox never sees them).
export JAX_COMPILATION_CACHE_DIR ?= $(HOME)/.cache/gfxlab/jax
export JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS ?= 0
export GFXLAB_LABS_OUT := $(abspath $(LABS_OUT))

.PHONY: lab test bench anchors lint format docs clean

# `mkdocs`, without jsonschema's IRI grammar: nbformat (under mkdocs-jupyter) imports
# jsonschema, which builds an Earley parser for the "iri" format at import (~2.5 s);
# notebooks use no such format (see gfxlab/_runner.py).
export MKDOCS := import sys; sys.modules.setdefault("rfc3987_syntax", None); \
	from mkdocs.__main__ import cli; cli()

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)

# Install an extra of gfxlab (editable) into the venv: with uv, fetched from PyPI by the
# venv's pip, when it can be had (measured: 17 s for the dev extra from an empty cache,
# against 96 s for pip with a warm one), else with pip itself. Compiled to bytecode at
# install, as pip does and uv does not by default: where PYTHONDONTWRITEBYTECODE is set
# (CI images often set it) every Python process would otherwise compile the sources of
# jax, scipy, matplotlib... anew (measured: 4 s more for each lab kernel, test worker
# and sandbox; the suite starts about a hundred of them).
INSTALL = $(BIN)/python -m pip install --quiet uv \
	&& $(BIN)/python -m uv pip install --quiet --compile-bytecode --python $(BIN)/python -e '.[$(1)]' \
	|| { echo "uv unavailable: installing with pip"; \
	     $(BIN)/python -m pip install --quiet --upgrade pip \
	     && $(BIN)/python -m pip install --quiet -e '.[$(1)]'; }

# Reinstall whenever the package metadata changes.
$(VENV)/.installed-lab: pyproject.toml setup.py | $(BIN)/python
	$(call INSTALL,lab)
	touch $@

$(VENV)/.installed-dev: pyproject.toml setup.py | $(BIN)/python
	$(call INSTALL,dev)
	touch $(VENV)/.installed-lab $@

# Jupyter refuses to run as root unless told to (containers, CI machines).
ROOT_FLAG := $(if $(filter 0,$(shell id -u)),--allow-root,)

# The kernels compile with the labs' XLA flag (gfxlab.labs.lab_xla_flags: a third faster).
lab: $(VENV)/.installed-lab
	XLA_FLAGS="$$($(BIN)/python -c 'import gfxlab.labs as l; print(l.lab_xla_flags())')" \
		$(BIN)/jupyter lab --notebook-dir=labs $(ROOT_FLAG) $(LAB_ARGS)

# pytest exits 5 when it collects nothing; that is not a failure of the suite.
test: $(VENV)/.installed-dev
	@rm -rf $(LABS_OUT); mkdir -p $(LABS_OUT)
	@$(BIN)/python -m compileall -q gfxlab  # its bytecode too (see INSTALL)
	@MPLBACKEND=Agg $(BIN)/python -m pytest -n $(WORKERS) --dist loadgroup --no-loadscope-reorder \
		--doctest-modules tests gfxlab; rc=$$?; \
	if [ $$rc -eq 5 ]; then echo "no tests collected"; rc=0; fi; [ $$rc -eq 0 ] || exit $$rc
	@$(MAKE) --no-print-directory lint
	@$(MAKE) --no-print-directory docs

# The renderer bench's hard-path anchor, jaxrenderer, pins an old JAX (< 0.5) and
# NumPy (< 2): it gets a pinned venv of its own, made once, when the render bench runs.
# Without it (no registry) the bench says so and skips that row.
ANCHOR_VENV := .venv-anchors/jaxrenderer
$(ANCHOR_VENV)/.installed: tests/benchmarks/anchors/jaxrenderer.txt
	$(PYTHON) -m venv $(ANCHOR_VENV)
	$(ANCHOR_VENV)/bin/python -m pip install --quiet --no-deps -r $<
	touch $@

anchors: $(ANCHOR_VENV)/.installed

bench: $(VENV)/.installed-dev
	@$(if $(or $(filter render,$(BENCH)),$(if $(BENCH),,all)),\
		$(MAKE) --no-print-directory anchors || echo "jaxrenderer's venv could not be made",:)
	MPLBACKEND=Agg $(BIN)/python tests/benchmarks/run.py $(BENCH)

lint: $(VENV)/.installed-dev
	$(BIN)/ruff check gfxlab tests labs
	$(BIN)/ruff format --check gfxlab tests labs

format: $(VENV)/.installed-dev
	$(BIN)/ruff format gfxlab tests labs
	$(BIN)/ruff check --fix gfxlab tests labs

# The site: API reference from the docstrings, the architecture, every lab executed.
# Labs already executed by `make test` are reused; otherwise they are run here.
docs: $(VENV)/.installed-dev
	@if ! ls $(LABS_OUT)/*.ipynb >/dev/null 2>&1; then \
		MPLBACKEND=Agg $(BIN)/python -m gfxlab run all --out $(LABS_OUT); fi
	NO_MKDOCS_2_WARNING=1 MPLBACKEND=Agg $(BIN)/python -c "$$MKDOCS" build --strict --quiet \
		--site-dir build/site

clean:
	rm -rf $(VENV) .venv-anchors build site *.egg-info .pytest_cache
