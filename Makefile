# lcnav: the README's two commands are `make demo` and `make test`.
# Both work on a fresh machine: they create .venv, install lcnav into it and,
# where the machine allows (root + apt-get), Debian's libllvm19 for Mitsuba's
# LLVM variant.

VENV    := .venv
PY      := $(VENV)/bin/python
STAMP   := $(VENV)/.lcnav-installed
export RERUN_ANALYTICS := 0
export MPLBACKEND := Agg

.PHONY: demo test test-slow lint bench readme system clean

demo: $(STAMP)
	$(VENV)/bin/lcnav demo --out runs/demo

# One pytest worker per core (pytest-xdist), each test file on one worker so that its module fixtures run once.
# `make test`: everything but the long physics runs (marked `slow`); `make test-slow`: those alone. CI runs both.
test: $(STAMP)
	$(PY) -m pytest -n auto --dist loadfile -m "not slow" --durations=15

test-slow: $(STAMP)
	$(PY) -m pytest -n auto --dist loadfile -m slow --durations=15

# ruff: pyflakes, pycodestyle (lines up to 160) and McCabe complexity (at most 12), as pyproject.toml's [tool.ruff] says.
lint: $(STAMP)
	$(PY) -m ruff check .

bench: $(STAMP)
	$(PY) -m benchmarks

# The README's demo section is the demo's own output (narrative and table), never typed by hand.
readme: demo
	$(PY) -m studies.engine.readme_sync runs/demo README.md

# Debian packages: libllvm19 (Mitsuba's llvm_* variants need libLLVM >= 16; without it lcnav runs
# scalar_rgb) and mesa-vulkan-drivers (software Vulkan, so `lcnav inspect --screenshot` can draw a
# recording with rerun's headless viewer on a machine with no GPU).
system:
	@need=""; \
	ls /usr/lib/*/libLLVM*.so* 2>/dev/null | grep -Eq 'LLVM(-|\.so\.)(1[6-9]|[2-9][0-9])' || need="$$need libllvm19"; \
	ls /usr/share/vulkan/icd.d/lvp_icd*.json >/dev/null 2>&1 || need="$$need mesa-vulkan-drivers"; \
	if [ -z "$$need" ]; then \
	    echo "Debian packages present (libLLVM >= 16, Mesa Vulkan)"; \
	elif [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then \
	    (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $$need >/dev/null) \
	    || echo "notice: could not install$$need (Mitsuba falls back to scalar_rgb; no headless screenshots)"; \
	else \
	    echo "notice: not root or no apt-get; not installed:$$need"; \
	fi

$(STAMP): pyproject.toml | system
	test -x $(PY) || python3 -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -e '.[test]'
	$(VENV)/bin/rerun analytics disable >/dev/null 2>&1 || true
	touch $(STAMP)

clean:
	rm -rf $(VENV) runs .pytest_cache
