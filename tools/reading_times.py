"""State each chapter's honest reading time (issue 39): in its header and in start_here's route.

The rule, stated in book/start_here.md and checked by tests/test_start_here.py and
tests/test_chapter_form.py: prose at 150 words a minute, 30 s a display equation, 6 s a line of
visible code, rounded up to a minute (the functions are the tests' own, so they cannot disagree).

    python tools/reading_times.py          # list each chapter's time and what it counts
    python tools/reading_times.py --write  # write the times into the headers and the route table

Writing touches only the header's "about <n> minutes to read" (in the jupytext source and in the
stored notebook's markdown cell alike: markdown has no outputs, so nothing needs re-executing)
and the route table's "| <n> min |".
"""

from __future__ import annotations

import json
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from prose_text import visible_code_lines  # noqa: E402
from test_start_here import (  # noqa: E402
    display_equations, prose_words, reading_minutes, route_rows, source_of)

UNITS = ("zero one two three four five six seven eight nine ten eleven twelve thirteen fourteen fifteen "
         "sixteen seventeen eighteen nineteen").split()
TENS = {2: "twenty", 3: "thirty", 4: "forty", 5: "fifty", 6: "sixty", 7: "seventy", 8: "eighty", 9: "ninety"}


def in_words(n: int) -> str:
    """0..99 in words, as the headers write them ("twenty-five")."""
    if n < 20:
        return UNITS[n]
    tens, units = divmod(n, 10)
    return TENS[tens] + (f"-{UNITS[units]}" if units else "")


HEADER_TIME = re.compile(r"about [a-z-]+ minutes to read")


def write_header(source: Path, minutes: int) -> bool:
    new = f"about {in_words(minutes)} minutes to read"
    text = source.read_text()
    if not HEADER_TIME.search(text) or HEADER_TIME.search(text).group(0) == new:
        return False
    source.write_text(HEADER_TIME.sub(new, text, count=1))
    notebook = source.with_suffix(".ipynb")
    if notebook.exists():
        data = json.loads(notebook.read_text())
        for cell in data["cells"]:
            if cell["cell_type"] == "markdown" and any(HEADER_TIME.search(line) for line in cell["source"]):
                cell["source"] = [HEADER_TIME.sub(new, line, count=1) for line in cell["source"]]
                break
        notebook.write_text(json.dumps(data, indent=1, ensure_ascii=False) + "\n")
    return True


def main(write: bool) -> None:
    start_here = ROOT / "book" / "start_here.md"
    route = start_here.read_text()
    for docs, stated in route_rows():
        sources = [source_of(f"book/{doc}") for doc in docs]
        minutes = reading_minutes(sources)
        for s in sources:
            print(f"{str(s.relative_to(ROOT)):42s} words {prose_words(s):5d}  display eqs {display_equations(s):3d}"
                  f"  code lines {visible_code_lines(s):4d}  -> {reading_minutes([s]):3d} min")
        if write:
            for s in sources:
                if s.suffix == ".py":
                    write_header(s, reading_minutes([s]))
            row = re.compile(r"^(\|[^\n]*\{doc\}`" + re.escape(docs[0]) + r"`[^\n]*\| )\d+( min \|)", re.M)
            route = row.sub(lambda m: f"{m.group(1)}{minutes}{m.group(2)}", route, count=1)
    if write:
        start_here.write_text(route)


if __name__ == "__main__":
    main("--write" in sys.argv[1:])
