"""State each chapter's honest reading time (issue 39): in its header and in start_here's route.

The rule, stated in book/start_here.md and checked by tests/test_start_here.py and
tests/test_chapter_form.py: prose at 150 words a minute, 30 s a display equation, 6 s a line of
visible code, rounded up to a minute; the folded blocks (evidence, "From the labs", folded code) by
the same rule; the exercises are named as extra (the functions are the tests' own, so they cannot
disagree).

    python tools/reading_times.py          # list each chapter's times and what they count
    python tools/reading_times.py --write  # write the times into the headers and the route table

Writing touches only the header's "**Time:**" line, which it writes whole (in the jupytext source
and in the stored notebook's markdown cell alike: markdown has no outputs, so nothing needs
re-executing):

    **Time:** about <n> minutes to read, plus about <m> minutes for the folded blocks; the exercises are extra.

and the route table's "| <n> min | <m> min |" columns, with its total row for the core route.
The header states no execution time: the README's benchmark section records those, with its machine.
"""

from __future__ import annotations

import json
import re
import sys
from pathlib import Path

import jupytext

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from prose_text import visible_code_lines  # noqa: E402
from test_start_here import (  # noqa: E402
    core_route_sources, display_equations, folded_counts, folded_minutes, prose_words, reading_minutes,
    route_rows, source_of)

UNITS = ("zero one two three four five six seven eight nine ten eleven twelve thirteen fourteen fifteen "
         "sixteen seventeen eighteen nineteen").split()
TENS = {2: "twenty", 3: "thirty", 4: "forty", 5: "fifty", 6: "sixty", 7: "seventy", 8: "eighty", 9: "ninety"}


def in_words(n: int) -> str:
    """0..99 in words, as the headers write them ("twenty-five")."""
    if n < 20:
        return UNITS[n]
    tens, units = divmod(n, 10)
    return TENS[tens] + (f"-{UNITS[units]}" if units else "")


def minutes_in_words(n: int) -> str:
    return f"{in_words(n)} minute{'' if n == 1 else 's'}"


def exercise_count(source: Path) -> int:
    return sum(c.source.count("```{exercise}") for c in jupytext.read(source).cells if c.cell_type == "markdown")


def time_line(source: Path) -> str:
    """The header's time, one line: the story by the rule, the folded blocks by the same rule, the exercises."""
    story, folded, exercises = reading_minutes([source]), folded_minutes([source]), exercise_count(source)
    line = f"**Time:** about {minutes_in_words(story)} to read"
    if folded:
        line += f", plus about {minutes_in_words(folded)} for the folded blocks"
    if exercises:
        line += "; the exercise is extra." if exercises == 1 else "; the exercises are extra."
    else:
        line += "."
    return line


#: The header's time paragraph in a jupytext source: from "# **Time:**" to the line before the closing ":::".
SOURCE_TIME = re.compile(r"^# \*\*Time:\*\*.*?\n(?=# :::\n)", re.M | re.S)


def write_header(source: Path) -> bool:
    """Write the header's time line into the source and its stored notebook; True if it changed."""
    new = time_line(source)
    text = source.read_text()
    found = SOURCE_TIME.search(text)
    if not found or found.group(0) == f"# {new}\n":
        return False
    source.write_text(text[:found.start()] + f"# {new}\n" + text[found.end():])
    notebook = source.with_suffix(".ipynb")
    if notebook.exists():
        data = json.loads(notebook.read_text())
        for cell in data["cells"]:
            lines = cell["source"]
            start = next((i for i, line in enumerate(lines) if line.startswith("**Time:**")), None)
            if cell["cell_type"] == "markdown" and start is not None:
                end = next(i for i in range(start, len(lines)) if lines[i].startswith(":::"))
                cell["source"] = lines[:start] + [new + "\n"] + lines[end:]
                break
        notebook.write_text(json.dumps(data, indent=1, ensure_ascii=False) + "\n")
    return True


def main(write: bool) -> None:
    start_here = ROOT / "book" / "start_here.md"
    route = start_here.read_text()
    for docs, _stated, _folded in route_rows():
        sources = [source_of(f"book/{doc}") for doc in docs]
        for s in sources:
            words, equations, code = folded_counts(s)
            print(f"{str(s.relative_to(ROOT)):38s} words {prose_words(s):5d}  eqs {display_equations(s):2d}"
                  f"  code {visible_code_lines(s):4d}  -> {reading_minutes([s]):3d} min; folded: words {words:5d}"
                  f"  eqs {equations:2d}  code {code:4d}  -> {folded_minutes([s]):3d} min")
        if write:
            for s in sources:
                if s.suffix == ".py":
                    write_header(s)
            row = re.compile(r"^(\|[^\n]*\{doc\}`" + re.escape(docs[0]) + r"`[^\n]*?\| )\d+ min \| \d+ min \|", re.M)
            route = row.sub(lambda m: f"{m.group(1)}{reading_minutes(sources)} min | {folded_minutes(sources)} min |",
                            route, count=1)
    core = core_route_sources()
    print(f"core route: {reading_minutes(core)} min to read, plus {folded_minutes(core)} min of folded blocks")
    if write:
        total = re.compile(r"^(\| [^|{}\n]*\| \*\*the core route\*\* \|[^\n]*?\| )\d+ min \| \d+ min \|", re.M)
        route = total.sub(lambda m: f"{m.group(1)}{reading_minutes(core)} min | {folded_minutes(core)} min |",
                          route, count=1)
        start_here.write_text(route)


if __name__ == "__main__":
    main("--write" in sys.argv[1:])
