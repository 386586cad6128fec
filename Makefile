# Every target creates .venv and installs the project when missing, so a fresh clone needs
# nothing but python3 (>= 3.11) and make.
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed-stamp

.PHONY: venv test test-browser demo bench lint clean

venv: $(STAMP)

$(STAMP): pyproject.toml
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[dev,plot]'
	touch $(STAMP)

# Both passes always run, and each reports, even when the first fails; make fails if either did.
test: $(STAMP)
	@parallel=0; serial=0; \
	$(PY) -m pytest -q -n 2 --dist loadfile -m "not serial" || parallel=$$?; \
	$(PY) -m pytest -q -m serial || serial=$$?; \
	echo "make test: parallel pass exit $$parallel, serial pass exit $$serial"; \
	[ $$parallel -eq 0 ] && [ $$serial -eq 0 ]

# The web console in headless Chromium (tests_browser/, not part of `make test`). Installs
# what is missing: the Debian packages chromium and chromium-driver (when root), and the
# `browser` extra (selenium) into .venv.
test-browser: $(STAMP)
	@if ! command -v chromium >/dev/null 2>&1 || ! command -v chromedriver >/dev/null 2>&1; then \
	    if [ "$$(id -u)" = 0 ]; then \
	        apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq \
	            chromium chromium-driver; \
	    else \
	        echo "test-browser needs chromium and chromium-driver: run as root, or" \
	             "sudo apt-get install -y chromium chromium-driver" >&2; exit 1; \
	    fi; \
	fi
	$(PY) -c 'import selenium' 2>/dev/null || $(PY) -m pip install --quiet -e '.[dev,plot,browser]'
	$(PY) -m pytest -q tests_browser

lint: $(STAMP)
	$(VENV)/bin/ruff check robodcn firmware_sim tests bench tests_browser
	$(VENV)/bin/lint-imports

# The showcase: three waypoints, KenLERP β = 0.5, auto duration, on a simulated arm.
demo: $(STAMP)
	mkdir -p out
	$(VENV)/bin/robodcn sim --arm configs/arm3r.toml \
	    --from 0.25,0.10,0 --via 0.12,0.24,60 --to -0.10,0.22,120 \
	    --method kenlerp --beta 0.5 --duration auto --plot out/demo.png

bench: $(STAMP)
	$(PY) -m pip install --quiet -e '.[dev,plot,bench]' || echo "optional bench extras unavailable; comparisons will be skipped"
	$(PY) -m bench

clean:
	rm -rf $(VENV) .pytest_cache .ruff_cache
