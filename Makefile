# lcnav: the README's two commands are `make demo` and `make test`.
# Both work on a fresh machine: they create .venv, install lcnav into it and,
# where the machine allows (root + apt-get), Debian's libllvm19 for Mitsuba's
# LLVM variant.

VENV    := .venv
PY      := $(VENV)/bin/python
STAMP   := $(VENV)/.lcnav-installed
export RERUN_ANALYTICS := 0
export MPLBACKEND := Agg

.PHONY: demo test bench system clean

demo: $(STAMP)
	$(VENV)/bin/lcnav demo --out runs/demo

test: $(STAMP)
	$(PY) -m pytest

bench: $(STAMP)
	$(PY) -m benchmarks

# Mitsuba's llvm_* variants need libLLVM >= 16; without it lcnav runs scalar_rgb.
system:
	@if ls /usr/lib/*/libLLVM*.so* 2>/dev/null | grep -Eq 'LLVM(-|\.so\.)(1[6-9]|[2-9][0-9])'; then \
	    echo "libLLVM >= 16 present"; \
	elif [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then \
	    (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq libllvm19 >/dev/null) \
	    || echo "notice: could not install libllvm19; Mitsuba will fall back to scalar_rgb"; \
	else \
	    echo "notice: not root or no apt-get; libllvm19 not installed, Mitsuba will fall back to scalar_rgb"; \
	fi

$(STAMP): pyproject.toml | system
	test -x $(PY) || python3 -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -e '.[test]'
	$(VENV)/bin/rerun analytics disable >/dev/null 2>&1 || true
	touch $(STAMP)

clean:
	rm -rf $(VENV) runs .pytest_cache
