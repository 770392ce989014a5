# Two entry points (see README): `make run` and `make test`.
# Both create the local virtual environment on first use and reuse it after.
PY ?= python3
VENV := .venv
STAMP := $(VENV)/.installed

.PHONY: run test clean

$(STAMP): pyproject.toml
	$(PY) -m venv $(VENV)
	$(VENV)/bin/pip install --quiet --upgrade pip
	$(VENV)/bin/pip install --quiet -e '.[test]'
	touch $(STAMP)

DAMPER ?= koni

run: $(STAMP)
	$(VENV)/bin/dyno run standard --damper $(DAMPER) --out recordings/standard-$(DAMPER).mcap --overwrite
	$(VENV)/bin/dyno report recordings/standard-$(DAMPER).mcap --out reports/standard-$(DAMPER)

test: $(STAMP)
	$(VENV)/bin/python -m pytest -q

clean:
	rm -rf $(VENV)
