# The two entry points of uqdrive. Each creates .venv if missing and installs what it needs.
# compileall: pip compiles what it installs, but not an editable package; where the environment
# sets PYTHONDONTWRITEBYTECODE, each of the ~150 Python processes of a run (Snakemake jobs, CLI
# calls) would otherwise compile uqdrive's modules anew (~0.25 s each).
VENV   := .venv
PYTHON := $(VENV)/bin/python
# The lock's packages without pip's one-file-at-a-time bytecode compilation, then compiled on every
# core, test suites of the packages left out (install 45 s -> ~36 s on 2 cores; the modules a run
# imports are compiled either way, which matters where PYTHONDONTWRITEBYTECODE is set).
COMPILE_VENV = $(PYTHON) -m compileall -q -j 0 -x '/tests?/' $(VENV)/lib
INSTALL_LOCK = $(PYTHON) -m pip install --quiet --no-compile -r requirements.lock && $(COMPILE_VENV)
# make reproduce: uqdrive with the lock as constraints, so only its own dependencies, at the lock's
# versions (not the test and docs extras: JAX alone is ~380 MB to unpack; install ~22 s -> ~16 s).
INSTALL_RUN = $(PYTHON) -m pip install --quiet --no-compile -c requirements.lock -e . && $(COMPILE_VENV)
CONFIG ?= config/config.yaml
CORES  ?= all

.PHONY: reproduce test bench clean

$(PYTHON):
	python3 -m venv $(VENV)
	$(PYTHON) -m pip install --quiet --upgrade pip

reproduce: $(PYTHON)
	$(INSTALL_RUN)
	@$(PYTHON) -m compileall -q src/uqdrive
	@$(PYTHON) workflow/profiles/default/stale_lock.py
	$(VENV)/bin/snakemake --cores $(CORES) --configfile $(CONFIG)
	$(VENV)/bin/snakemake --cores $(CORES) --configfile $(CONFIG) --report results/report.html --report-stylesheet workflow/report/report.css reported
	@echo "report: results/report.html, scorecard: results/scorecard.csv"

# make sweep SWEEP=config/sweeps/NAME.yaml: every point into results/sweeps/NAME/<point>/, then
# results/sweeps/NAME/summary.{nc,csv,png}, then the report (docs/workflow.md, "Changing and sweeping config values").
# The target comes first: --configfile takes every word after it as a config file.
.PHONY: sweep
sweep: $(PYTHON)
	@test -f config/sweeps/$(basename $(notdir $(SWEEP))).yaml || { echo "usage: make sweep SWEEP=config/sweeps/NAME.yaml (one of: $(notdir $(wildcard config/sweeps/*.yaml)))"; exit 2; }
	$(PYTHON) -m pip install --quiet -e .
	$(VENV)/bin/snakemake results/sweeps/$(basename $(notdir $(SWEEP)))/summary.csv --cores $(CORES) --configfile $(CONFIG)
	$(VENV)/bin/snakemake --cores $(CORES) --configfile $(CONFIG) --report results/report.html --report-stylesheet workflow/report/report.css reported
	@echo "summary: results/sweeps/$(basename $(notdir $(SWEEP)))/summary.csv, report: results/report.html"

test: $(PYTHON)
	$(INSTALL_LOCK)
	$(PYTHON) -m pip install --quiet --no-deps -e ".[test,docs]"
	@$(PYTHON) -m compileall -q src/uqdrive
	$(PYTHON) -m pytest

# make docs: the documentation site into docs/_build/html (open docs/_build/html/index.html).
# Warnings are errors; --keep-going lists all of them before failing. tests/test_docs.py runs the
# same build (SPHINX_BUILD below) inside make test, so CI builds the site on every run.
SPHINX_BUILD = -m sphinx -b html -W --keep-going -q -j auto
.PHONY: docs
docs: $(PYTHON)
	$(INSTALL_LOCK)
	$(PYTHON) -m pip install --quiet --no-deps -e ".[docs]"
	$(PYTHON) $(SPHINX_BUILD) docs docs/_build/html
	@echo "docs: docs/_build/html/index.html"

# requirements.lock: the exact versions make reproduce, make test and make docs install
# (pyproject.toml keeps lower bounds for library users). Refreshed from a fresh venv with uqdrive
# and its test and docs extras.
.PHONY: lock
lock:
	tmp=$$(mktemp -d) && trap 'rm -rf "$$tmp"' EXIT && \
	python3 -m venv "$$tmp/venv" && \
	"$$tmp/venv/bin/python" -m pip install --quiet --upgrade pip && \
	"$$tmp/venv/bin/python" -m pip install --quiet -e ".[test,docs]" && \
	{ echo "# Exact versions of uqdrive's dependencies and its test and docs extras: make reproduce, make test"; \
	  echo "# and make docs install these, then uqdrive itself with --no-deps. Written by make lock ($$("$$tmp/venv/bin/python" -V), $$(uname -sm))."; \
	  "$$tmp/venv/bin/python" -m pip freeze --exclude-editable; } > requirements.lock.new && \
	mv requirements.lock.new requirements.lock
	@echo "requirements.lock: $$(grep -vc '^#' requirements.lock) packages"

bench: $(PYTHON)
	$(PYTHON) -m pip install --quiet -e .
	$(PYTHON) benchmarks/bench_montecarlo.py
	$(PYTHON) benchmarks/bench_pce.py
	$(PYTHON) benchmarks/bench_identify.py
	$(PYTHON) benchmarks/bench_discover.py
	$(PYTHON) benchmarks/bench_posterior.py
	$(PYTHON) benchmarks/bench_chassis.py
	$(PYTHON) benchmarks/bench_profile_batch.py
	$(PYTHON) benchmarks/bench_ltv.py
	$(PYTHON) benchmarks/bench_import.py

clean:
	rm -rf results .snakemake

# Mutation testing of the core modules (issue 17): on demand, not in CI. tools/mutate.py mutates
# a copy of the repository in a temporary directory, one mutant at a time, and runs the tests
# that import each module; e.g. make mutation MUTATION_ARGS="--module gp --sample 40 --seed 2".
MUTATION_ARGS ?= --sample 60 --seed 1
.PHONY: mutation
mutation: $(PYTHON)
	$(PYTHON) -m pip install --quiet -e ".[test]"
	$(PYTHON) tools/mutate.py $(MUTATION_ARGS)

# make check-report: opens results/report.html in headless Chromium (Debian's chromium package,
# installed here if missing) and fails, with a list, if a figure, a table or the landing page does
# not render; writes screenshots of the landing page and of every category (tools/check_report.py).
APT := $(if $(filter 0,$(shell id -u)),,sudo )apt-get
.PHONY: check-report
check-report: $(PYTHON)
	@command -v chromium >/dev/null || { $(APT) update -q && $(APT) install -y chromium; }
	$(PYTHON) tools/check_report.py results/report.html --screenshots results/report_screenshots
