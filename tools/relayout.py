"""Move pfcourse's modules to the 0.4 layout and rewrite every reference to them (issue 44, item 4).

The layout (README, "The package"): the library's core at the top level of ``pfcourse`` (engine,
resampling, proposals, Kalman family, smoothing, PMMH, diagnostics, metrics, seeding, the evidence (statistics of paired runs), the methods
of the likelihood); the scenarios under ``pfcourse.scenarios``; the studies (registry, runner,
store, record, provenance, the executor) under ``pfcourse.studies``; the book's
machinery (style, narrow copies, legibility, figures, panels, report, exercises) under
``pfcourse.book``, which imports the library and is never imported by it.

:data:`MOVES` is the table old module -> new module (a package moves with every module in it,
also modules added later; a longer entry overrides a shorter one).  ``python tools/relayout.py``

1. moves every file of ``pfcourse/`` whose module the table maps elsewhere (``git mv`` for a
   tracked file), creates the new packages' ``__init__.py`` and removes emptied folders;
2. rewrites every reference in the ``.py`` files under ``pfcourse/``, ``tests/``, ``tools/``,
   ``book/``, ``bench/``, ``browser_tests/``, ``pdf_tests/`` and the root, in ``README.md``,
   ``_config.yml`` and ``book/**/*.md``, and in the code and markdown cells of the stored
   notebooks ``book/**/*.ipynb`` (their outputs untouched, nothing executed, the file written
   as nbformat writes it): dotted names (``pfcourse.figures.report``, in code, strings, comments
   and prose), paths (``pfcourse/figures/report.py``), ``from pfcourse.figures import report``
   (split when the names now live in different packages) and relative imports (made absolute);
   an import line of a chapter that the longer path makes wider than 80 characters is wrapped.

It is idempotent (a second run changes nothing: no new name starts with an old one) and, run
again after other branches are merged, moves and rewrites what they added at the old paths.
``--dry-run`` lists the moves and the files it would rewrite; ``--check`` exits 1 if any.
"""

from __future__ import annotations

import argparse
import ast
import io
import json
import re
import shutil
import subprocess
import sys
import tokenize
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

#: old module -> new module (packages move whole; the longest matching entry wins).
MOVES: dict[str, str] = {
    # scenarios: one package, each scenario with its simulation
    "pfcourse.landmarks": "pfcourse.scenarios.landmarks",
    "pfcourse.robot": "pfcourse.scenarios.robot",
    "pfcourse.terrain": "pfcourse.scenarios.terrain",
    "pfcourse.maprobot": "pfcourse.scenarios.maprobot",
    # studies: registry, runner, store, record, provenance, the studies' rows; their executor loop
    "pfcourse.experiments": "pfcourse.studies",
    "pfcourse.executor": "pfcourse.studies.executor",
    # methods, not studies: the likelihood of a parameter by the filter and by Kalman (core)
    "pfcourse.experiments.likelihood": "pfcourse.likelihood",
    # the book's machinery: never imported by the library
    "pfcourse.style": "pfcourse.book.style",
    "pfcourse.narrow_figures": "pfcourse.book.narrow_figures",
    "pfcourse.exercises": "pfcourse.book.exercises",
    "pfcourse.figures": "pfcourse.book.figures",
    "pfcourse.figures.report": "pfcourse.book.report",
    "pfcourse.figures.legibility": "pfcourse.book.legibility",
    "pfcourse.figures.widgets": "pfcourse.book.panels",
    "pfcourse.figures.static_panel": "pfcourse.book.static_panel",
    "pfcourse.landmarks.figures": "pfcourse.book.figures.landmarks",
    "pfcourse.robot.figures": "pfcourse.book.figures.robot",
    "pfcourse.maprobot.figures": "pfcourse.book.figures.maprobot",
}

#: The new packages' ``__init__.py`` (made when missing).
NEW_PACKAGES: dict[str, str] = {
    "pfcourse.scenarios": '"""The scenarios: landmarks (scenario A), the robot, the terrain flights, the robot on a map.\n\n'
                          'Each one a subpackage with its scenario, simulation, model and Kalman-family references;\n'
                          'they import the core and themselves, never one another."""\n',
    "pfcourse.book": '"""The book\'s machinery: style, figures, panels, narrow copies, legibility, report, exercises.\n\n'
                     'It imports the library (the core, the scenarios, the studies) and the library never imports\n'
                     'it, so ``import pfcourse`` needs no matplotlib."""\n',
}

#: Files that keep the old names (the table itself and its test's fixtures).
EXCLUDE = {"tools/relayout.py", "tests/test_relayout.py"}
SKIP_DIRS = {".git", ".venv", "_build", "node_modules", "__pycache__", ".ipynb_checkpoints", ".pytest_cache"}
WIDTH = 80  # a chapter's visible code line


def new_name(module: str, moves: dict[str, str] = MOVES) -> str:
    """``module`` in the new layout (unchanged when no entry of ``moves`` is a prefix of it)."""
    parts = module.split(".")
    for i in range(len(parts), 1, -1):
        head = ".".join(parts[:i])
        if head in moves:
            return ".".join([moves[head], *parts[i:]])
    return module


def module_of(rel: Path) -> str:
    parts = list(rel.with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def path_of(module: str, package: bool) -> Path:
    base = Path(*module.split("."))
    return base / "__init__.py" if package else base.with_suffix(".py")


def git(*args: str, root: Path) -> str:
    return subprocess.run(["git", *args], cwd=root, check=True, capture_output=True, text=True).stdout


# ------------------------------------------------------------------------------------------ moves

def planned_moves(root: Path, moves: dict[str, str] = MOVES) -> list[tuple[Path, Path, bool]]:
    """``(old, new, tracked)`` paths (relative to root) of the files of ``pfcourse/`` that move."""
    tracked = set(git("ls-files", "pfcourse", root=root).split())
    untracked = set(git("ls-files", "--others", "--exclude-standard", "pfcourse", root=root).split())
    out = []
    for name in sorted(tracked | untracked):
        rel = Path(name)
        if rel.suffix != ".py" or not (root / rel).exists():
            continue
        module = module_of(rel)
        target = new_name(module, moves)
        if target != module:
            out.append((rel, path_of(target, rel.name == "__init__.py"), name in tracked))
    return out


FILE_PARENTS = re.compile(r"(__file__\)(?:\.resolve\(\))?\.parents\[)(\d+)\]")


def apply_moves(root: Path, plan, dry_run: bool) -> None:
    for old, new, tracked in plan:
        print(f"move {old} -> {new}")
        if dry_run:
            continue
        if (root / new).exists():
            raise SystemExit(f"relayout: {new} exists already; move {old} by hand")
        (root / new).parent.mkdir(parents=True, exist_ok=True)
        if tracked:
            git("mv", str(old), str(new), root=root)
        else:
            (root / old).rename(root / new)
        depth = len(new.parts) - len(old.parts)
        if depth:  # a path found from the module's own file (the repository's root, book/data) keeps its target
            text = (root / new).read_text(encoding="utf-8")
            fixed = FILE_PARENTS.sub(lambda m: f"{m.group(1)}{int(m.group(2)) + depth}]", text)
            if fixed != text:
                (root / new).write_text(fixed, encoding="utf-8")
                print(f"parents of __file__ in {new} shifted by {depth}")
    if dry_run:
        return
    # every folder of pfcourse with modules is a package; the new ones get their docstring
    package = root / "pfcourse"
    folders = {parent for p in package.rglob("*.py") if "__pycache__" not in p.parts
               for parent in p.parents if parent == package or package in parent.parents}
    for folder in sorted(folders):
        init = folder / "__init__.py"
        if not init.exists():
            module = module_of(init.relative_to(root))
            init.write_text(NEW_PACKAGES.get(module, f'"""{module}."""\n'))
            git("add", str(init.relative_to(root)), root=root)
            print(f"create {init.relative_to(root)}")
    # folders left with compiled caches only
    for folder in sorted((root / "pfcourse").rglob("*"), key=lambda p: -len(p.parts)):
        if folder.is_dir() and folder.name != "__pycache__" and not any(
                f.is_file() and "__pycache__" not in f.relative_to(folder).parts for f in folder.rglob("*")):
            shutil.rmtree(folder)
            print(f"remove {folder.relative_to(root)}/")


# ------------------------------------------------------------------------------------- rewriting

DOTTED = re.compile(r"(?<![\w.])pfcourse(?:\.\w+)+")
ESCAPED = re.compile(r"(?<![\w.])pfcourse(?:\\\.\w+)+")  # in a regular expression: pfcourse\.exercises
SLASHED = re.compile(r"(?<![\w/.])pfcourse(?:/\w+)+(?:\.py\b|/)?")
FROM_LINE = re.compile(r"^(\s*)from (pfcourse[\w.]*) import ([\w ,]+?)(\s*#.*)?$")


def rewrite_names(line: str, moves: dict[str, str]) -> str:
    """Dotted and slashed module names of ``line`` in the new layout."""
    line = DOTTED.sub(lambda m: new_name(m.group(0), moves), line)
    line = ESCAPED.sub(lambda m: new_name(m.group(0).replace("\\.", "."), moves).replace(".", "\\."), line)

    def slashed(m: re.Match) -> str:
        text = m.group(0)
        suffix = ".py" if text.endswith(".py") else "/" if text.endswith("/") else ""
        module = text[: len(text) - len(suffix)].replace("/", ".")
        return new_name(module, moves).replace(".", "/") + suffix
    return SLASHED.sub(slashed, line)


def wrap_import(line: str, width: int = WIDTH) -> str:
    """``from M import a, b`` wrapped in parentheses when wider than ``width``."""
    m = FROM_LINE.match(line)
    if len(line) <= width or not m:
        return line
    indent, module, names, comment = m.group(1), m.group(2), m.group(3), m.group(4) or ""
    head = f"{indent}from {module} import ({comment.rstrip()}"
    rows, row = [], indent + "    "
    for name in [n.strip() for n in names.split(",") if n.strip()]:
        piece = name + ", "
        if len(row) + len(piece) > width and row.strip():
            rows.append(row.rstrip())
            row = indent + "    "
        row += piece
    rows.append(row.rstrip().rstrip(",") + ")")
    return "\n".join([head, *rows])


def is_module(module: str, root: Path) -> bool:
    base = root / Path(*module.split("."))
    return base.with_suffix(".py").exists() or (base / "__init__.py").exists()


def split_from_imports(source: str, root: Path, moves: dict[str, str], here: str | None, width: int) -> str:
    """Rewrite ``from P import x`` whose ``x`` are modules that now live elsewhere than ``P``'s new
    place, and relative imports of a module ``here`` of pfcourse (made absolute)."""
    try:
        tree = ast.parse(source)
    except SyntaxError:
        return source
    lines = source.splitlines(keepends=True)
    edits = []
    for node in ast.walk(tree):
        if not isinstance(node, ast.ImportFrom):
            continue
        module = node.module or ""
        if node.level:
            if here is None:
                continue
            package = here.split(".")[: len(here.split(".")) - node.level]
            module = ".".join(package + ([module] if module else []))
        if module.split(".")[0] != "pfcourse":
            continue
        groups: dict[str, list[str]] = {}
        for alias in node.names:
            full = new_name(f"{module}.{alias.name}", moves)
            if alias.name != "*" and is_module(full, root):
                parent, leaf = full.rsplit(".", 1)
                name = leaf if leaf == alias.name and alias.asname is None else f"{leaf} as {alias.asname or alias.name}"
                if leaf == (alias.asname or alias.name):
                    name = leaf
            else:
                parent = new_name(module, moves)
                name = alias.name if alias.asname is None else f"{alias.name} as {alias.asname}"
            groups.setdefault(parent, []).append(name)
        if not node.level and list(groups) == [new_name(module, moves)]:
            continue  # only the module's name changes: the line rewrite keeps its formatting
        first = lines[node.lineno - 1]
        indent = first[: len(first) - len(first.lstrip())]
        comments = [m.group(0) for line in lines[node.lineno - 1: node.end_lineno]
                    for m in [re.search(r"#.*$", line.rstrip("\n"))] if m]
        comment_text = "  " + " ".join(comments) if comments else ""
        statements = []
        for parent, names in groups.items():
            one = f"{indent}from {parent} import {', '.join(names)}"
            statements.append(wrap_import(one, width) if len(one) > width else one)
        statements[0] += comment_text
        edits.append((node.lineno - 1, node.end_lineno, "\n".join(statements) + "\n"))
    for start, end, text in sorted(edits, reverse=True):
        lines[start:end] = [text]
    return "".join(lines)


def string_spans(source: str) -> dict[int, list[tuple[int, int]]]:
    """``{line index: [(start, end) columns]}`` of the string literals of ``source``."""
    spans: dict[int, list[tuple[int, int]]] = {}
    try:
        tokens = list(tokenize.generate_tokens(io.StringIO(source).readline))
    except (tokenize.TokenError, SyntaxError, IndentationError):
        return spans
    for tok in tokens:
        if tok.type != tokenize.STRING and tok.type != getattr(tokenize, "FSTRING_MIDDLE", -1):
            continue
        (r0, c0), (r1, c1) = tok.start, tok.end
        for r in range(r0, r1 + 1):
            spans.setdefault(r - 1, []).append((c0 if r == r0 else 0, c1 if r == r1 else 10**9))
    return spans


def outside_strings(body: str, spans: list[tuple[int, int]], rewrite) -> str:
    """``rewrite`` applied to the parts of the line ``body`` outside the string ``spans``."""
    out, at = [], 0
    for start, end in sorted(spans):
        out += [rewrite(body[at:start]), body[start:end]]
        at = max(at, end)
    return "".join(out + [rewrite(body[at:])]) if at < len(body) else "".join(out)


#: Names in the string literals of chapters' code that were left as they are (their outputs print
#: them; strict nbval compares them): listed at the end for the authors.
KEPT_IN_STRINGS: list[str] = []


def rewrite_code(source: str, root: Path, moves: dict[str, str], here: str | None = None,
                 wrap: bool = False, keep_strings: bool = False) -> str:
    """``source`` (Python) with every reference to a moved module in the new layout (with
    ``keep_strings``, those in string literals stay: a chapter's printed output must not move)."""
    width = WIDTH if wrap else 10**6
    source = split_from_imports(source, root, moves, here, width)
    spans = string_spans(source) if keep_strings else {}
    out = []
    for i, line in enumerate(source.splitlines(keepends=True)):
        body = line.rstrip("\n")
        if i in spans:
            new = outside_strings(body, spans[i], lambda part: rewrite_names(part, moves))
            kept = [m.group(0) for m in DOTTED.finditer(body) if new_name(m.group(0), moves) != m.group(0)
                    and m.group(0) in new]
            KEPT_IN_STRINGS.extend(kept)
        else:
            new = rewrite_names(body, moves)
        if new != body and wrap and len(body) <= WIDTH:
            new = wrap_import(new, WIDTH)
        out.append(new + line[len(body):])
    return "".join(out)


def rewrite_text(text: str, moves: dict[str, str]) -> str:
    """Prose (markdown, YAML): dotted and slashed names only."""
    return "".join(rewrite_names(line.rstrip("\n"), moves) + line[len(line.rstrip("\n")):]
                   for line in text.splitlines(keepends=True))


def rewrite_notebook(text: str, root: Path, moves: dict[str, str]) -> str:
    """A stored notebook with its code and markdown cells rewritten, its outputs as they were."""
    nb = json.loads(text)
    for cell in nb.get("cells", []):
        source = "".join(cell["source"]) if isinstance(cell["source"], list) else cell["source"]
        if cell["cell_type"] == "code":
            # magics are not Python: hide them from the parser, keep them as they are
            masked = re.sub(r"(?m)^(\s*)([%!])", r"\1#\2MAGIC", source)
            new = rewrite_code(masked, root, moves, wrap=True, keep_strings=True)
            new = re.sub(r"(?m)^(\s*)#([%!])MAGIC", r"\1\2", new)
        elif cell["cell_type"] == "markdown":
            new = rewrite_text(source, moves)
        else:
            continue
        if new != source:
            cell["source"] = new.splitlines(keepends=True) if isinstance(cell["source"], list) else new
    return json.dumps(nb, sort_keys=True, indent=1, ensure_ascii=False) + "\n"


def files_to_rewrite(root: Path):
    def walk(folder: Path, pattern: str):
        if not folder.exists():
            return
        for path in sorted(folder.rglob(pattern)):
            if not SKIP_DIRS.intersection(path.relative_to(root).parts):
                yield path
    for folder in ("pfcourse", "tests", "tools", "book", "bench", "browser_tests", "pdf_tests"):
        yield from walk(root / folder, "*.py")
    yield from sorted(root.glob("*.py"))
    yield from walk(root / "book", "*.md")
    yield from walk(root / "book", "*.ipynb")
    for name in ("README.md", "_config.yml"):
        if (root / name).exists():
            yield root / name


def stale_outputs(text: str, moves: dict[str, str]) -> list[str]:
    """Old module names in a notebook's stored outputs (left as they are; listed for the reader)."""
    nb = json.loads(text)
    found = set()
    for cell in nb.get("cells", []):
        for output in cell.get("outputs", []):
            blob = json.dumps(output)
            found |= {m.group(0) for m in DOTTED.finditer(blob) if new_name(m.group(0), moves) != m.group(0)}
    return sorted(found)


def absolute_imports(root: Path, dry_run: bool) -> None:
    """Relative imports of pfcourse's modules made absolute, before anything moves."""
    for path in sorted((root / "pfcourse").rglob("*.py")):
        if "__pycache__" in path.parts:
            continue
        text = path.read_text(encoding="utf-8")
        new = split_from_imports(text, root, {}, module_of(path.relative_to(root)), 10**6)
        if new != text:
            print(f"absolute imports in {path.relative_to(root)}")
            if not dry_run:
                path.write_text(new, encoding="utf-8")


def rewrite_all(root: Path, moves: dict[str, str], dry_run: bool) -> list[Path]:
    changed = []
    for path in files_to_rewrite(root):
        rel = path.relative_to(root).as_posix()
        if rel in EXCLUDE:
            continue
        text = path.read_text(encoding="utf-8")
        if path.suffix == ".py":
            before = len(KEPT_IN_STRINGS)
            chapter = rel.startswith("book/")
            new = rewrite_code(text, root, moves, wrap=chapter, keep_strings=chapter)
            for name in sorted(set(KEPT_IN_STRINGS[before:])):
                print(f"note: {rel}: {name} kept in a string of the code (its output prints it)")
        elif path.suffix == ".ipynb":
            new = rewrite_notebook(text, root, moves)
            for name in stale_outputs(text, moves):
                print(f"note: {rel}: a stored output names {name} (outputs are not rewritten)")
        else:
            new = rewrite_text(text, moves)
        if new != text:
            changed.append(path)
            print(f"rewrite {rel}")
            if not dry_run:
                path.write_text(new, encoding="utf-8")
    return changed


def relayout(root: Path = ROOT, moves: dict[str, str] = MOVES, dry_run: bool = False) -> tuple[list, list]:
    """Move and rewrite (see the module's docstring); the moves and the rewritten files."""
    absolute_imports(root, dry_run)
    plan = planned_moves(root, moves)
    apply_moves(root, plan, dry_run)
    changed = rewrite_all(root, moves, dry_run)
    return plan, changed


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--dry-run", action="store_true", help="list the moves and rewrites, change nothing")
    parser.add_argument("--check", action="store_true", help="exit 1 if anything would move or change")
    parser.add_argument("--root", type=Path, default=ROOT)
    args = parser.parse_args(argv)
    plan, changed = relayout(args.root, dry_run=args.dry_run or args.check)
    print(f"relayout: {len(plan)} files moved, {len(changed)} files rewritten")
    return 1 if args.check and (plan or changed) else 0


if __name__ == "__main__":
    sys.exit(main())
