"""Run lcnav's benchmarks and write ``benchmarks/RESULTS.md``.

``python -m benchmarks`` (``make bench``) runs every ``benchmarks/bench_*.py``;
``python -m benchmarks dynamics lightcurves`` runs the named ones and keeps
the other sections of RESULTS.md as they were. Each module has
``run() -> str`` returning a Markdown section (a ``## Title`` and tables).
Speed is reported as measured here and as ratios against baselines measured
in the same run; nothing here is asserted.
"""

from __future__ import annotations

import datetime
import importlib
import os
import platform
import re
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
RESULTS = HERE / "RESULTS.md"


def _machine() -> str:
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return f"{cpu}, {os.cpu_count()} cores, Python {platform.python_version()}, {platform.system()} {platform.release()}"


def _sections(text: str) -> dict[str, str]:
    out = {}
    for m in re.finditer(r"<!-- bench:(\w+) -->\n(.*?)<!-- /bench:\1 -->\n", text, re.S):
        out[m.group(1)] = m.group(2)
    return out


def main(names: list[str]) -> None:
    sys.path.insert(0, str(HERE.parent))
    from benchmarks.provenance import commit

    code = commit()  # before the run: the checkout may change while a long benchmark runs
    available = sorted(p.stem[len("bench_"):] for p in HERE.glob("bench_*.py"))
    unknown = [n for n in names if n not in available]
    if unknown:
        raise SystemExit(f"unknown benchmark(s) {unknown}; available: {available}")
    chosen = names or available
    new = {}
    for name in chosen:
        print(f"[bench] {name} ...", flush=True)
        mod = importlib.import_module(f"benchmarks.bench_{name}")
        body = mod.run().rstrip() + "\n"
        new[name] = f"_Measured {datetime.date.today().isoformat()} on {_machine()}, commit {code}._\n\n" + body
        print(body)
    # read the other sections only now: a benchmark run meanwhile in another process keeps what it wrote
    old = _sections(RESULTS.read_text()) if RESULTS.exists() else {}
    old.update(new)
    parts = ["# Benchmark results\n", "Written by `make bench` (`python -m benchmarks [NAME ...]`). Each section states",
             "the machine and date it was measured on; ratios compare against baselines", "measured in the same run.\n"]
    for name in available:
        if name in old:
            parts.append(f"<!-- bench:{name} -->\n{old[name]}<!-- /bench:{name} -->\n")
    tmp = RESULTS.with_suffix(".md.tmp")
    tmp.write_text("\n".join(parts))
    os.replace(tmp, RESULTS)
    print(f"[bench] wrote {RESULTS}")


if __name__ == "__main__":
    main(sys.argv[1:])
