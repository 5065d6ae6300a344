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

# Two worker processes, a test file each at a time (its module fixtures built once), handed
# out in collection order, where tests/conftest.py puts the end-to-end pipeline files first
# (xdist's default hands out the files with most tests first: the quick pipeline's file,
# with 6, then started 25 minutes in); the slowest tests listed at the end.
test: $(STAMP)
	$(PY) -m pytest -n 2 --dist loadfile --no-loadscope-reorder --durations=25

bench: $(STAMP)
	$(PY) bench/bench_rom.py
	$(PY) bench/bench_tensile.py
	$(PY) bench/bench_branch.py

clean-results:
	rm -rf results .snakemake
