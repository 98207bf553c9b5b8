#!/usr/bin/env python3
"""The project's commands. Each one sets up .venv/ from requirements.txt first (once).

    python3 tasks.py build       build the HTML book into _build/html (warnings are errors)
    python3 tasks.py test        unit tests + strict `pytest --nbval` on every notebook
    python3 tasks.py notebooks   regenerate book/**/*.ipynb from their .py sources and execute them
    python3 tasks.py lab         open the notebooks in JupyterLab (widgets live)
    python3 tasks.py bench       benchmark against a lab-style loop and `particles` (bench/bench.py)

Extra arguments after `test` go to pytest; after `notebooks`, they name the sources to run;
after `bench`, see `python3 tasks.py bench --help`.
Only the Python standard library is used here, so a fresh machine needs nothing but Python 3.11.
"""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys
import venv
from pathlib import Path

# One BLAS thread: on this 2-core machine OpenBLAS's threads make the small (N, d) @ (d, d)
# products of the filters 4-30 times slower (measured in bench/), and the kernels, pytest and
# the benchmark inherit this setting.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

ROOT = Path(__file__).resolve().parent
VENV = ROOT / ".venv"
BIN = VENV / ("Scripts" if os.name == "nt" else "bin")
PY = BIN / "python"
STAMP = VENV / ".requirements.sha256"
BOOK = ROOT / "book"


def run(*cmd: str | Path, **kw) -> None:
    print("+", " ".join(str(c) for c in cmd), flush=True)
    subprocess.run([str(c) for c in cmd], check=True, cwd=kw.pop("cwd", ROOT), **kw)


def ensure_venv() -> None:
    """Create .venv and install requirements.txt unless it is already up to date."""
    digest = hashlib.sha256(
        (ROOT / "requirements.txt").read_bytes() + (ROOT / "pyproject.toml").read_bytes()
    ).hexdigest()
    if STAMP.exists() and STAMP.read_text().strip() == digest and PY.exists():
        return
    if not PY.exists():
        print(f"creating the virtual environment {VENV}", flush=True)
        venv.EnvBuilder(with_pip=True).create(VENV)
    run(PY, "-m", "pip", "install", "--disable-pip-version-check", "-q", "-r", "requirements.txt")
    STAMP.write_text(digest + "\n")


def build(args: list[str]) -> None:
    run(BIN / "jupyter-book", "build", ".", "--warningiserror", "--nitpick", "--keep-going", *args)
    print(f"\nThe book is at {ROOT / '_build' / 'html' / 'index.html'}")


def test(args: list[str]) -> None:
    run(PY, "-m", "pytest", "--nbval", "--nbval-sanitize-with", "book/nbval_sanitize.cfg", *args)


def notebooks(args: list[str]) -> None:
    sources = [Path(a).resolve() for a in args] or sorted(BOOK.rglob("*.py"))
    run(PY, ROOT / "tools" / "execute_notebooks.py", *sources)


def bench(args: list[str]) -> None:
    run(PY, ROOT / "bench" / "bench.py", *args)


def lab(args: list[str]) -> None:
    run(BIN / "jupyter", "lab", *args, cwd=BOOK)


COMMANDS = {"build": build, "test": test, "notebooks": notebooks, "lab": lab, "bench": bench}


def main() -> int:
    if len(sys.argv) < 2 or sys.argv[1] not in COMMANDS:
        print(__doc__)
        return 2
    ensure_venv()
    try:
        COMMANDS[sys.argv[1]](sys.argv[2:])
    except subprocess.CalledProcessError as exc:
        return exc.returncode
    return 0


if __name__ == "__main__":
    sys.exit(main())
