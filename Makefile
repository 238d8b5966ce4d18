# The two entry points of uqdrive. Each creates .venv if missing and installs what it needs.
VENV   := .venv
PYTHON := $(VENV)/bin/python
CONFIG ?= config/config.yaml
CORES  ?= all

.PHONY: reproduce test bench clean

$(PYTHON):
	python3 -m venv $(VENV)
	$(PYTHON) -m pip install --quiet --upgrade pip

reproduce: $(PYTHON)
	$(PYTHON) -m pip install --quiet -e .
	$(VENV)/bin/snakemake --cores $(CORES) --configfile $(CONFIG)
	$(VENV)/bin/snakemake --cores $(CORES) --configfile $(CONFIG) --report results/report.html
	@echo "report: results/report.html, scorecard: results/scorecard.csv"

test: $(PYTHON)
	$(PYTHON) -m pip install --quiet -e ".[test]"
	$(PYTHON) -m pytest

bench: $(PYTHON)
	$(PYTHON) -m pip install --quiet -e .
	$(PYTHON) benchmarks/bench_montecarlo.py
	$(PYTHON) benchmarks/bench_pce.py
	$(PYTHON) benchmarks/bench_identify.py

clean:
	rm -rf results .snakemake
