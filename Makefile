# Two entry points for a fresh machine (only python3 >= 3.10 with venv is needed):
#   make demo   - build .venv, then simulate, interpret and plot a synthetic XLOT
#   make test   - build .venv, then run the test suite
# and for the synthetic library (data/synthetic, docs/synthetic-library.md):
#   make synthetic  - simulate every library scene again, replacing its log and truth
#                     (about 1 h: 99-473 s a scene measured on 2 shared cores;
#                     `xlotkit library check data/synthetic` then picks the logs)
PYTHON ?= python3
VENV ?= .venv
BIN := $(VENV)/bin
OUT ?= results/demo

.PHONY: demo test test-all bench inspect-field synthetic clean

$(BIN)/.installed: pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test]'
	touch $@

demo: $(BIN)/.installed
	$(BIN)/xlotkit demo --out $(OUT)

test: $(BIN)/.installed
	$(BIN)/python -m pytest -m "not slow" -q

test-all: $(BIN)/.installed
	$(BIN)/python -m pytest -q

synthetic: $(BIN)/.installed
	$(BIN)/xlotkit library build data/synthetic --replace

inspect-field: $(BIN)/.installed
	$(BIN)/xlotkit inspect ../shared/data/field/AMS-01/*Data*

clean:
	rm -rf $(VENV) build *.egg-info src/*.egg-info
