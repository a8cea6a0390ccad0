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

.PHONY: setup run test bench docs
setup: $(BIN)/dacm

run: setup
	$(BIN)/dacm sweep --force
	$(BIN)/dacm design --range 5 --force

test: setup
	MPLBACKEND=Agg $(BIN)/python -m pytest -q -n 2 --dist loadfile; status=$$?; \
	if [ $$status -eq 5 ]; then echo "pytest collected no tests: failing"; exit 1; fi; exit $$status

docs: setup
	PATH=$(CURDIR)/$(BIN):$$PATH MPLBACKEND=Agg $(BIN)/python scripts/make_docs.py --dacm $(BIN)/dacm

bench: setup
	for f in tests/benchmarks/*.py; do $(BIN)/python $$f; done
