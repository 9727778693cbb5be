"""Keep the README's demo section in step with what the demo printed: ``python -m studies.engine.readme_sync [DEMO_DIR] [README]``.

``make readme`` runs ``make demo`` and then this module, which replaces the
text between :data:`BEGIN` and :data:`END` in the README with the demo's
narrative (``narrative.txt``, as a code block) and its comparison table (the
Markdown table of ``summary.md``). Nothing else in the README changes; the
README is rewritten atomically.
"""

from __future__ import annotations

import sys
from pathlib import Path

from studies.engine.io import write_text

BEGIN = "<!-- demo-output:begin (written by `make readme` from runs/demo; edit the demo, not this block) -->"
END = "<!-- demo-output:end -->"


def markdown_table(summary_md: str) -> str:
    """The first Markdown table (header, rule and rows) of ``summary_md``."""
    lines = summary_md.splitlines()
    start = next((i for i, line in enumerate(lines) if line.startswith("|")), None)
    if start is None:
        raise ValueError("summary.md holds no Markdown table (a line starting with '|')")
    end = start
    while end < len(lines) and lines[end].startswith("|"):
        end += 1
    return "\n".join(lines[start:end])


def demo_block(demo_dir) -> str:
    """The README block for the demo output in ``demo_dir``: narrative code block, then the comparison table."""
    demo_dir = Path(demo_dir)
    for name in ("narrative.txt", "summary.md"):
        if not (demo_dir / name).is_file():
            raise FileNotFoundError(f"{demo_dir / name} not found: run `make demo` first")
    narrative = (demo_dir / "narrative.txt").read_text().rstrip("\n")
    table = markdown_table((demo_dir / "summary.md").read_text())
    return f"```\n{narrative}\n```\n\n{table}\n"


def splice(readme: str, block: str) -> str:
    """``readme`` with the text between :data:`BEGIN` and :data:`END` replaced by ``block``."""
    if readme.count(BEGIN) != 1 or readme.count(END) != 1:
        raise ValueError(f"the README must hold exactly one {BEGIN!r} and one {END!r} line")
    head, rest = readme.split(BEGIN)
    _, tail = rest.split(END)
    return f"{head}{BEGIN}\n{block}{END}{tail}"


def main(argv: list[str]) -> int:
    demo_dir = Path(argv[0]) if argv else Path("runs/demo")
    readme = Path(argv[1]) if len(argv) > 1 else Path("README.md")
    try:
        write_text(readme, splice(readme.read_text(), demo_block(demo_dir)))
    except (OSError, ValueError) as e:
        print(f"readme_sync: error: {e}", file=sys.stderr)
        return 2
    print(f"readme_sync: {readme} demo section now shows {demo_dir}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
