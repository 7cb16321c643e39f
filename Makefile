# Flank Toolpath -- developer entry points.
# A fresh machine needs only python3.11 and make: every target that needs
# Python creates/refreshes ./.venv first (stamp keyed on the pins below).
SHELL := /bin/bash
.DEFAULT_GOAL := help

PYTHON311 ?= python3.11
VENV      ?= .venv
PY        := $(VENV)/bin/python

# Exact pins of the development venv (Blender 5.0 as a Python module).
# bpy 5.0.1 is built against numpy 1.26 (Requires-Dist numpy<2,>=1.26);
# scipy 1.17.1 is the same version that tools/build_extension.py bundles.
# pytest-xdist (with its execnet) runs the tests on every core: see XDIST below and tests/conftest.py.
PINS := bpy==5.0.1 numpy==1.26.4 scipy==1.17.1 pytest==9.2.0 pytest-xdist==3.8.0 execnet==2.1.2

# Test workers: one per core (TEST_JOBS=1 runs in-process, TEST_JOBS=4 forces four).  loadgroup keeps the tests of
# one expensive module fixture (a plan, a Blender scenario run) on one worker and tests/conftest.py starts
# the longest work units first.
TEST_JOBS ?= auto
XDIST := $(if $(filter 1,$(TEST_JOBS)),,-n $(TEST_JOBS) --dist loadgroup)

# Compatibility venvs (Blender tests only; no scipy on purpose so the
# bundled scipy wheel inside the extension is what gets imported).
COMPAT42_VENV := .venv-bpy42
COMPAT42_PINS := bpy==4.2.23 numpy==1.26.4 pytest==9.2.0
COMPAT5X_VENV := .venv-bpy52
COMPAT5X_PINS := bpy==5.2.3 numpy==2.3.5 pytest==9.2.0
# Python 3.13 is optional: detected, never required.
PYTHON313 ?= $(firstword $(wildcard $(HOME)/.pyenv/versions/3.13*/bin/python3.13) $(shell command -v python3.13 2>/dev/null))

# Platforms for `make extension` (all by default); e.g. PLATFORMS=linux-x64
PLATFORMS ?= all

pins_key = $(firstword $(shell printf '%s' '$(1)' | cksum))
STAMP          := $(VENV)/.pins-$(call pins_key,$(PINS))
COMPAT42_STAMP := $(COMPAT42_VENV)/.pins-$(call pins_key,$(COMPAT42_PINS))
COMPAT5X_STAMP := $(COMPAT5X_VENV)/.pins-$(call pins_key,$(COMPAT5X_PINS))

# $(1)=python interpreter, $(2)=venv dir, $(3)=pins, $@=stamp
define make_venv
	@if [ ! -x "$(2)/bin/python" ]; then echo "creating $(2) with $(1)"; "$(1)" -m venv "$(2)"; fi
	"$(2)/bin/python" -m pip install --quiet --upgrade pip
	"$(2)/bin/python" -m pip install --quiet $(3)
	@rm -f "$(2)"/.pins-*
	@touch "$@"
endef

.PHONY: help venv demo test test-core test-blender extension test-compat bench figures clean distclean

help:
	@echo "make demo         generate + analyze the built-in asymmetric female rotor -> out/"
	@echo "make test         core tests (tests/*.py) + Blender tests (tests/blender/)"
	@echo "make extension    build + validate installable zips into dist/ (PLATFORMS=all|linux-x64,...)"
	@echo "make test-compat  Blender tests against bpy 4.2 LTS, 5.0 and 5.2 (5.2 only if Python 3.13 is found)"
	@echo "make bench        run bench/*.py"
	@echo "make figures      render the README pictures into docs/ (headless Workbench)"
	@echo "make clean        remove build outputs (distclean also removes venvs and wheels/)"

venv: $(STAMP)

$(STAMP):
	$(call make_venv,$(PYTHON311),$(VENV),$(PINS))

demo: $(STAMP)
	$(PY) tools/demo.py

test: $(STAMP)
	$(PY) -m pytest $(XDIST)

test-core: $(STAMP)
	$(PY) -m pytest $(XDIST) tests --ignore=tests/blender

test-blender: $(STAMP)
	$(PY) -m pytest $(XDIST) tests/blender

extension: $(STAMP)
	$(PY) tools/build_extension.py --platforms $(PLATFORMS)

$(COMPAT42_STAMP):
	$(call make_venv,$(PYTHON311),$(COMPAT42_VENV),$(COMPAT42_PINS))

$(COMPAT5X_STAMP):
	$(call make_venv,$(PYTHON313),$(COMPAT5X_VENV),$(COMPAT5X_PINS))

# bpy 4.2 LTS, bpy 5.0 (the dev venv) and bpy 5.2 (only when Python 3.13 is found): every leg always runs,
# a summary line per leg (pytest's counts, wall seconds) comes last, and the target fails at the end if any
# leg failed or its venv could not be made.
test-compat:
	@set -o pipefail; status=0; summary=""; log=$$(mktemp); \
	leg() { \
	  echo "=== Blender tests with $$1 ($$2) ==="; t0=$$(date +%s); \
	  if "$$2" -m pytest -p no:cacheprovider tests/blender 2>&1 | tee "$$log"; then r=ok; else r=FAILED; status=1; fi; \
	  summary="$${summary}$$1: $$(tail -n 1 "$$log" | tr -d '=' | sed 's/^ *//; s/ *$$//') [$$r, wall $$(( $$(date +%s) - t0 )) s]\n"; \
	}; \
	novenv() { status=1; summary="$${summary}$$1: FAILED, the venv $$2 could not be made\n"; }; \
	if $(MAKE) --no-print-directory $(COMPAT42_STAMP); then leg "$(firstword $(COMPAT42_PINS))" $(COMPAT42_VENV)/bin/python; \
	else novenv "$(firstword $(COMPAT42_PINS))" $(COMPAT42_VENV); fi; \
	if $(MAKE) --no-print-directory $(STAMP); then leg "$(firstword $(PINS))" $(PY); \
	else novenv "$(firstword $(PINS))" $(VENV); fi; \
	if [ -z "$(strip $(PYTHON313))" ]; then \
	  echo "SKIP: bpy 5.x compatibility tests -- no Python 3.13 found (~/.pyenv/versions/3.13*/bin/python3.13 or python3.13 on PATH)"; \
	  summary="$${summary}$(firstword $(COMPAT5X_PINS)): SKIPPED, no Python 3.13 found\n"; \
	elif $(MAKE) --no-print-directory $(COMPAT5X_STAMP); then leg "$(firstword $(COMPAT5X_PINS))" $(COMPAT5X_VENV)/bin/python; \
	else novenv "$(firstword $(COMPAT5X_PINS))" $(COMPAT5X_VENV); fi; \
	rm -f "$$log"; \
	echo "=== test-compat summary ==="; printf '%b' "$$summary"; \
	exit $$status

figures: $(STAMP)
	$(PY) tools/render_figures.py
	PYTHONPATH=. $(PY) tools/freeform_figures.py --out docs
	@[ -f out/demo_plan.json ] || $(PY) tools/demo.py
	PYTHONPATH=. $(PY) -m flank_addon render out/demo_plan.json --out docs/report.png --resolution 960 600

bench: $(STAMP)
	@shopt -s nullglob; files=(bench/*.py); \
	if [ $${#files[@]} -eq 0 ]; then echo "no bench/*.py yet"; exit 0; fi; \
	for f in "$${files[@]}"; do echo "=== $$f"; PYTHONPATH=. $(PY) "$$f" || exit 1; done

clean:
	rm -rf dist out build .pytest_cache
	find . -name __pycache__ -type d -not -path './.venv*' -prune -exec rm -rf {} +

distclean: clean
	rm -rf $(VENV) $(COMPAT42_VENV) $(COMPAT5X_VENV) wheels
