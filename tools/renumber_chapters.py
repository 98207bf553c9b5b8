"""Renumber "Algorithm n.m" and exercise numbers after a chapter is inserted into the parts.

The book numbers a chapter by its place among the parts' chapters (tests/test_chapter_form.py), and
its algorithm boxes and exercises carry that number ("Algorithm 5.1", ``{exercise} 5.3``), as do the
references to them from other chapters ("see Algorithm 17.1"). After a chapter is inserted before
chapter ``n``, every number from ``n`` on moves up by one:

    python tools/renumber_chapters.py FIRST_SHIFTED [--by 1]

It edits every chapter source (book/**/*.py), its stored notebook's markdown cells (markdown has no
outputs: nothing needs re-executing), the book's pages (book/**/*.md) and the exercise checkers'
comments ("chapter 18", "exercise 18.1"). A stored notebook's code cell that prints such a number is
not changed: regenerate that notebook.
"""

from __future__ import annotations

import argparse
import json
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
NUMBERED = re.compile(r"((?:Algorithm|Exercise|Exercises|exercise|\{exercise\}) )(\d+)(\.\d+)")
#: "chapter 18" in the exercise checkers' comments and docstrings.
CHAPTER = re.compile(r"(\bchapter )(\d+)()\b")


def shifted(text: str, first: int, by: int, patterns=(NUMBERED,)) -> str:
    for pattern in patterns:
        text = pattern.sub(lambda m: m.group(1) + str(int(m.group(2)) + by if int(m.group(2)) >= first
                                                      else m.group(2)) + m.group(3), text)
    return text


def main(first: int, by: int) -> None:
    for source in sorted((ROOT / "book").rglob("*.py")):
        lines = source.read_text().split("\n")
        # only comment lines of markdown cells and docstrings are prose; shifting a code line is harmless
        # only if it holds such a reference, which the regex requires
        source.write_text(shifted("\n".join(lines), first, by))
        notebook = source.with_suffix(".ipynb")
        if notebook.exists():
            data = json.loads(notebook.read_text())
            for cell in data["cells"]:
                if cell["cell_type"] == "markdown":
                    cell["source"] = shifted("".join(cell["source"]), first, by).splitlines(keepends=True)
            notebook.write_text(json.dumps(data, indent=1, ensure_ascii=False) + "\n")
    for page in sorted((ROOT / "book").glob("**/*.md")):
        page.write_text(shifted(page.read_text(), first, by))
    for module in sorted((ROOT / "pfcourse" / "exercises").glob("*.py")):
        module.write_text(shifted(module.read_text(), first, by, (NUMBERED, CHAPTER)))


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("first", type=int)
    parser.add_argument("--by", type=int, default=1)
    args = parser.parse_args()
    main(args.first, args.by)
