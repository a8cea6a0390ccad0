# Two entry points for a fresh clone: `make run` (the main job: the default sweep with its
# equal-range answers and Figure 49 contour plots, then the 5 N design, into ./dacm-out) and
# `make test`; `make docs` regenerates the README's images in docs/ from the commands.
PY ?= python3
VENV := .venv
BIN := $(VENV)/bin

$(BIN)/dacm: pyproject.toml
	$(PY) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet -e '.[test]'
	touch $(BIN)/dacm

# numba compiles the solver's kernels on first use and caches them beside the source: doing
# it here makes the first `dacm sweep` as fast as the next (tests/benchmarks/first_run.py);
# redone when the kernels change.
KERNELS := $(VENV)/.kernels-compiled
$(KERNELS): $(BIN)/dacm sensor/mechanics/_solver_kernel.py
	$(BIN)/dacm solve --preset sample-b > /dev/null
	touch $@

.PHONY: setup run test bench docs
setup: $(BIN)/dacm $(KERNELS)

run: setup
	$(BIN)/dacm sweep --force
	$(BIN)/dacm design --range 5 --force

test: setup
	MPLBACKEND=Agg $(BIN)/python -m pytest -q -n 2 --dist loadfile --durations=25; status=$$?; \
	if [ $$status -eq 5 ]; then echo "pytest collected no tests: failing"; exit 1; fi; exit $$status

docs: setup
	PATH=$(CURDIR)/$(BIN):$$PATH MPLBACKEND=Agg $(BIN)/python scripts/make_docs.py --dacm $(BIN)/dacm

# the peers: OpenSeesPy in the project's venv (its Linux wheel needs the system's libblas3
# and liblapack3), hazen in a venv of its own (it pins numpy < 2.4)
HAZEN_VENV := .venv-hazen
$(VENV)/.bench: $(BIN)/dacm
	$(BIN)/pip install --quiet -e '.[bench]'
	touch $@
$(HAZEN_VENV)/bin/python:
	$(PY) -m venv $(HAZEN_VENV)
	$(HAZEN_VENV)/bin/pip install --quiet "hazen>=2.0,<3"

bench: setup $(VENV)/.bench $(HAZEN_VENV)/bin/python
	for f in solve sweep first_run scale snr datasheet plant loop design verify; do \
		$(BIN)/python -m tests.benchmarks.$$f || exit 1; done
