# Two commands on a fresh machine: `make demo` and `make test`.
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python

.PHONY: demo test lint test-lowest check-wheel bench report ablation screenshot clean

$(PY):
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip

# An editable install whose package is a tree of links (setuptools' strict mode), not an
# import hook: type checkers (mypy) find fuzzynav through it. A new module file needs
# the install again (make clean, or touch pyproject.toml).
EDITABLE := --config-settings editable_mode=strict

$(VENV)/.installed: pyproject.toml | $(PY)
	$(PY) -m pip install --quiet -e . $(EDITABLE)
	touch $@

$(VENV)/.installed-test: pyproject.toml | $(PY)
	$(PY) -m pip install --quiet -e '.[test]' $(EDITABLE)
	touch $@ $(VENV)/.installed

demo: $(VENV)/.installed
	$(VENV)/bin/fuzzynav demo

test: $(VENV)/.installed-test
	$(PY) -m pytest -n 2 --durations=15

# ruff, with the project's configuration (pyproject.toml), and mypy over the package.
lint: $(VENV)/.installed-test
	$(VENV)/bin/ruff check .
	$(VENV)/bin/ruff format --check .
	PY=$(PY) bash .ci/typecheck.sh

# The whole suite with every runtime dependency at its declared lower bound.
LOWEST := .venv-lowest
test-lowest: $(VENV)/.installed-test
	$(PY) .ci/lowest_constraints.py > .ci/lowest-constraints.txt
	test -x $(LOWEST)/bin/python || $(PYTHON) -m venv $(LOWEST)
	$(LOWEST)/bin/python -m pip install --quiet --upgrade pip
	$(LOWEST)/bin/python -m pip install --quiet -c .ci/lowest-constraints.txt -e '.[test]' $(EDITABLE)
	$(LOWEST)/bin/python -m pip list 2>/dev/null | grep -iE '^(numpy|scipy|pymunk|viser|rerun-sdk|rich|matplotlib|cma|tomli_w|tomli-w) '
	$(LOWEST)/bin/python -m pytest -n 2 -q -p no:cacheprovider

# The built wheel, installed outside the checkout and used from an empty folder.
check-wheel: $(VENV)/.installed-test
	PY=$(PY) bash .ci/check_wheel.sh

bench: $(VENV)/.installed-test
	for b in bench/bench_*.py; do echo "== $$b"; $(PY) $$b || exit 1; done

report: $(VENV)/.installed
	$(VENV)/bin/fuzzynav report out/report --geometry both --readme-images docs/img --force
	cp out/report/figures/paper/fig12_s1_trajectory_paper.png docs/img/paper_geometry_s1_trajectory.png
	cp out/report/figures/paper/fig19_s2_angles_paper.png docs/img/paper_geometry_s2_angles.png
	cp out/report/figures/paper/fig26_s3_voltages_paper.png docs/img/paper_geometry_s3_voltages.png
	$(PY) scripts/paper_design_figure.py
	$(PY) scripts/paper_behaviour_figure.py
	$(PY) scripts/fuzzynav_figure.py
	$(PY) scripts/crossing_figure.py
	$(PY) scripts/jitter_figure.py
	$(PY) scripts/doubt_figure.py
	$(PY) scripts/fuzzynav_ablation.py --from-json docs/data/fuzzynav_ablation_seed59.json

# What each part of fuzzynav buys, run again (about 30 minutes on 2 cores).
ablation: $(VENV)/.installed
	$(PY) scripts/fuzzynav_ablation.py --seed 59 --json docs/data/fuzzynav_ablation_seed59.json

screenshot: $(VENV)/.installed-test
	$(PY) scripts/screenshot.py
	$(PY) scripts/screenshot.py --scenario crossing --controller fuzzynav --seconds 9 --out docs/img/viewer_fuzzynav.png

clean:
	rm -rf $(VENV) $(LOWEST) .pytest_cache .hypothesis .ci/lowest-constraints.txt
