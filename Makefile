# lift-gl: set up from a fresh clone and run.
#   make test   system check, .venv, editable install, then the test suite (2 workers)
#   make demo   same set-up, then a headless render of the Cornell box to out/cornell.png,
#               then the viewer on it when $DISPLAY is set
#   make clean  remove outputs and caches; make distclean also removes .venv

PYTHON ?= python3
VENV   := .venv
VPY    := $(VENV)/bin/python
STAMP  := $(VENV)/.lift-gl-installed
PYTEST_ARGS ?=

.PHONY: all test demo system venv clean distclean

all: test

system:
	@bash scripts/setup_system.sh

$(VPY):
	$(PYTHON) -m venv $(VENV)

# Reinstall only when pyproject.toml changes (or the venv is new).
$(STAMP): pyproject.toml | $(VPY)
	$(VPY) -m pip install -e '.[test]'
	@touch $@

venv: system $(STAMP)

test: venv
	$(VPY) -m pytest -n 2 --durations=10 tests/ $(PYTEST_ARGS)

demo: venv
	@mkdir -p out
	$(VENV)/bin/lift-gl render scenes/cornell.toml --spp 256 --size 256x256 --out out/cornell.png
	@if [ -n "$$DISPLAY" ] && $(VENV)/bin/lift-gl view --help >/dev/null 2>&1; then \
		$(VENV)/bin/lift-gl view scenes/cornell.toml; \
	else \
		echo "demo: image in out/cornell.png (no viewer: DISPLAY unset or the viewer extra not installed)"; \
	fi

clean:
	rm -rf out .pytest_cache build
	find . -path ./$(VENV) -prune -o -name __pycache__ -type d -prune -exec rm -rf {} +

distclean: clean
	rm -rf $(VENV) *.egg-info
