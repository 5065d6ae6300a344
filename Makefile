# Two commands from a fresh clone:  make reproduce [PROFILE=quick]  |  make test
# Both create .venv when missing and install the package (editable) into it.
PYTHON ?= python3
VENV   ?= .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed
PROFILE ?= default

.PHONY: reproduce test venv bench clean-results

$(STAMP): pyproject.toml
	@test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[test]'
	@touch $(STAMP)

venv: $(STAMP)

reproduce: $(STAMP)
	$(VENV)/bin/snakemake --cores 2 --config profile=$(PROFILE)

# Two worker processes, a test file each at a time (its module fixtures built once);
# the end-to-end pipeline files start first (tests/conftest.py), the slowest listed at the end.
test: $(STAMP)
	$(PY) -m pytest -n 2 --dist loadfile --durations=25

bench: $(STAMP)
	$(PY) bench/bench_rom.py
	$(PY) bench/bench_tensile.py
	$(PY) bench/bench_branch.py

clean-results:
	rm -rf results .snakemake
