#!/usr/bin/env python3
"""The project's commands. Each one sets up .venv/ from requirements.txt first (once).

    python3 tasks.py build         build the HTML book into _build/html (warnings are errors)
    python3 tasks.py test          unit tests + strict `pytest --nbval` on every notebook
    python3 tasks.py browser-test  every built page in a real browser (chromium), network blocked
    python3 tasks.py pdf           the printed book, _build/latex/particle-filters-measured.pdf (XeLaTeX,
                                   installed with apt-get when missing), then its test
    python3 tasks.py notebooks     regenerate book/**/*.ipynb from their .py sources and execute them
    python3 tasks.py lab           open the notebooks in JupyterLab (widgets live)
    python3 tasks.py bench         benchmark against a lab-style loop and `particles` (bench/bench.py)
    python3 tasks.py knife-edge    execute notebooks with a last-bit perturbation of the arithmetic
                                   and list the stored outputs that change (tools/perturbed_arithmetic.py)
    python3 tasks.py study NAME    run the heavy study NAME of pfcourse.studies.registry and store
                                   it under book/data/ (with its provenance)

Extra arguments after `test` and `browser-test` go to pytest; after `notebooks`, they name
the sources to run; after `bench`, see `python3 tasks.py bench --help`. Only the Python
standard library is used here. `build` also needs npm (node 20): the JavaScript the book serves itself (MathJax, require.js, the widget manager,
the animation icons) is installed with `npm ci` from web/package-lock.json. `browser-test`
needs Debian's chromium at /usr/bin/chromium and installs it with apt-get when missing.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import sys
import venv
from pathlib import Path

# One BLAS thread: on this 2-core machine OpenBLAS's threads make the small (N, d) @ (d, d)
# products of the filters 4-30 times slower (measured in bench/), and the kernels, pytest and
# the benchmark inherit this setting.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

ROOT = Path(__file__).resolve().parent


def load_arithmetic():
    """pfcourse/arithmetic.py, loaded by path: it needs only the standard library."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("_pfcourse_arithmetic", ROOT / "pfcourse" / "arithmetic.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up there
    spec.loader.exec_module(module)
    return module


# One arithmetic on every x86-64 CPU (pfcourse/arithmetic.py): NumPy without its AVX-512 paths
# and OpenBLAS with its Haswell (AVX2) kernels, in this process and in everything it starts
# (pytest, the notebook kernels of nbval and of `notebooks`, JupyterLab, the benchmark), so a
# seeded result is the same float on AVX2 and AVX-512 machines, Intel and AMD.
ARITHMETIC = load_arithmetic()
ARITHMETIC.pin_environment()
VENV = ROOT / ".venv"
BIN = VENV / ("Scripts" if os.name == "nt" else "bin")
PY = BIN / "python"
STAMP = VENV / ".requirements.sha256"
BOOK = ROOT / "book"
BUILD = ROOT / "_build"
HTML = BUILD / "html"
WEB = ROOT / "web"
# html_static_path of the book (_config.yml): copied into _build/html/_static at each build.
# Not book/_static, whose .js/.css files jupyter-book would inject into every page.
OFFLINE = BUILD / "offline_static"
CHROMIUM = Path("/usr/bin/chromium")

# What the book serves itself, from web/node_modules (versions pinned in web/package.json and
# web/package-lock.json) to _static/npm/: (source, target) pairs, files or whole folders.
VENDOR = [
    ("mathjax/LICENSE", "mathjax/LICENSE"),
    ("mathjax/es5/tex-mml-chtml.js", "mathjax/tex-mml-chtml.js"),
    *((f"mathjax/es5/{d}", f"mathjax/{d}") for d in ("a11y", "adaptors", "input", "output", "sre", "ui")),
    ("requirejs/require.js", "requirejs/require.js"),
    ("requirejs/README.md", "requirejs/README.md"),
    ("@jupyter-widgets/html-manager/dist", "html-manager"),
    ("font-awesome/css/font-awesome.min.css", "font-awesome/css/font-awesome.min.css"),
    ("font-awesome/fonts", "font-awesome/fonts"),
    ("font-awesome/README.md", "font-awesome/README.md"),
]
# Not used by the book: source maps, the widget manager's non-AMD build and its library alone
# (embed-amd.js defines the library's module itself, by name), font formats no current browser asks
# for (Font Awesome's and the widget manager's CSS list woff2 first), and the speech rules of
# MathJax's other languages (the book is English: en.json, base.json and nemeth.json stay).
VENDOR_SKIP = ("*.map", "embed.js", "embed.js.LICENSE.txt", "libembed-amd.js", "*.eot", "*.ttf", "*.otf",
               "fontawesome-webfont.svg",
               *(f"{language}.json" for language in ("ca", "da", "de", "es", "fr", "hi", "it", "nb", "nn", "sv")))


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


def digest_of(*paths: Path, extra: str = "") -> str:
    h = hashlib.sha256(extra.encode())
    for path in paths:
        h.update(path.read_bytes())
    return h.hexdigest()


def vendor_assets() -> None:
    """Install the book's JavaScript with `npm ci` and copy it into the book's static folder.

    Without these files the book would load MathJax, require.js and the widget manager from
    CDNs and show raw LaTeX offline, so a missing npm is an error, not a silent fallback.
    """
    lock = WEB / "package-lock.json"
    digest = digest_of(WEB / "package.json", lock, extra=repr((VENDOR, VENDOR_SKIP, "npm")))
    stamp = OFFLINE / ".vendor.sha256"
    if stamp.exists() and stamp.read_text().strip() == digest:
        return
    installed = WEB / "node_modules" / ".pfcourse.sha256"
    if not (installed.exists() and installed.read_text().strip() == digest_of(lock)):
        npm = shutil.which("npm")
        if npm is None:
            sys.exit(
                "error: npm not found. The book serves MathJax, require.js and the Jupyter widget\n"
                "manager itself (so that it renders with no network); they are installed with\n"
                "`npm ci` from web/package-lock.json. Install Node.js 20 and npm (Debian:\n"
                "`apt-get install -y nodejs npm`), then run this command again."
            )
        run(npm, "ci", "--ignore-scripts", "--no-audit", "--no-fund", "--loglevel=error", cwd=WEB)
        installed.write_text(digest_of(lock) + "\n")
    if OFFLINE.exists():
        shutil.rmtree(OFFLINE)
    for source, target in VENDOR:
        src, dst = WEB / "node_modules" / source, OFFLINE / "npm" / target
        dst.parent.mkdir(parents=True, exist_ok=True)
        if src.is_dir():
            shutil.copytree(src, dst, ignore=shutil.ignore_patterns(*VENDOR_SKIP))
        else:
            shutil.copy2(src, dst)
    stamp.write_text(digest + "\n")
    print(f"copied the book's JavaScript from web/node_modules into {OFFLINE}", flush=True)


def build(args: list[str]) -> None:
    vendor_assets()
    run(BIN / "jupyter-book", "build", ".", "--warningiserror", "--nitpick", "--keep-going", *args)
    print(f"\nThe book is at {ROOT / '_build' / 'html' / 'index.html'}")


def ensure_chromium() -> None:
    """Install Debian's chromium (the browser the browser test drives) if it is missing."""
    if CHROMIUM.exists():
        return
    apt = shutil.which("apt-get")
    if apt is None:
        sys.exit(f"error: {CHROMIUM} is missing and there is no apt-get to install Debian's chromium")
    sudo = [] if os.geteuid() == 0 else ["sudo"]
    if sudo and shutil.which("sudo") is None:
        sys.exit(f"error: {CHROMIUM} is missing; as root: apt-get update && apt-get install -y chromium")
    env = dict(os.environ, DEBIAN_FRONTEND="noninteractive")
    run(*sudo, apt, "update", "-q", env=env)
    run(*sudo, apt, "install", "-y", "-q", "chromium", env=env)


def browser_test(args: list[str]) -> None:
    """Build the book (incrementally: only what changed), then test every page in chromium."""
    ensure_chromium()
    build([])
    shutil.rmtree(BUILD / "browser" / "screenshots", ignore_errors=True)  # no stale pages
    run(PY, "-m", "pytest", "browser_tests", *args)
    print(f"\nScreenshots of every page: {BUILD / 'browser' / 'screenshots'}")


#: Debian's packages the printed book needs: XeLaTeX with the LaTeX packages Sphinx and jupyter-book use,
#: latexmk, the FreeSerif/FreeSans fonts, and poppler's tools for its test.
TEX_PACKAGES = ("texlive-latex-recommended", "texlive-latex-extra", "texlive-fonts-recommended", "texlive-xetex",
                "latexmk", "fonts-freefont-otf", "poppler-utils")


def apt_install(packages: tuple[str, ...], missing: bool) -> None:
    if not missing:
        return
    apt = shutil.which("apt-get")
    if apt is None:
        sys.exit(f"error: needs Debian's {' '.join(packages)} and there is no apt-get to install them")
    sudo = [] if os.geteuid() == 0 else ["sudo"]
    env = dict(os.environ, DEBIAN_FRONTEND="noninteractive")
    run(*sudo, apt, "update", "-q", env=env)
    run(*sudo, apt, "install", "-y", "-q", *packages, env=env)


def pdf(args: list[str]) -> None:
    """The printed book, _build/latex/particle-filters-measured.pdf (XeLaTeX), then its test (pdf_tests/)."""
    apt_install(TEX_PACKAGES, missing=not all(shutil.which(t) for t in ("xelatex", "latexmk", "pdftotext")))
    shutil.rmtree(BUILD / "latex", ignore_errors=True)  # latexmk takes a failed run's leftovers as up to date
    run(BIN / "jupyter-book", "build", ".", "--builder", "pdflatex", *args)
    run(PY, "-m", "pytest", "pdf_tests", "-p", "no:cacheprovider")
    print(f"\nThe printed book is {BUILD / 'latex' / 'particle-filters-measured.pdf'}")


def test(args: list[str]) -> None:
    if ARITHMETIC.reproduces_stored_outputs():
        mode = "--nbval"  # every stored output compared, bit for bit
    else:
        # Another platform (ARM, macOS, Windows, an x86-64 CPU without AVX2): its libraries
        # round differently, so stored floats cannot be reproduced. Every unit test runs, and
        # every notebook is executed top to bottom and must raise no error; its outputs are
        # compared only in cells marked `# NBVAL_CHECK_OUTPUT` (platform-independent ones).
        mode = "--nbval-lax"
        print(
            "note: this platform does not reproduce the book's stored floats bit for bit (only\n"
            "Linux on x86-64 with AVX2 does, see README). Running every unit test, and every\n"
            "notebook without comparing its stored outputs (pytest --nbval-lax).",
            flush=True,
        )
    run(PY, "-m", "pytest", mode, "--nbval-sanitize-with", "book/nbval_sanitize.cfg", *args)


def notebooks(args: list[str]) -> None:
    sources = [Path(a).resolve() for a in args] or sorted(BOOK.rglob("*.py"))
    run(PY, ROOT / "tools" / "execute_notebooks.py", *sources)


def bench(args: list[str]) -> None:
    run(PY, ROOT / "bench" / "bench.py", *args)


def knife_edge(args: list[str]) -> None:
    run(PY, ROOT / "tools" / "perturbed_arithmetic.py", *args)


def study(args: list[str]) -> None:
    """Run the registered study (or group) NAME (pfcourse.studies.registry; stored under book/data/)
    in the pinned environment."""
    if not args:
        raise SystemExit("usage: python3 tasks.py study NAME [ARGS...] (the registered studies: "
                         "pfcourse.studies.registry.STUDIES)")
    run(PY, "-m", "pfcourse.studies.registry", *args)


def lab(args: list[str]) -> None:
    """JupyterLab on book/ as a reader gets it (tools/lab_glue.py, reader_lab): the prose's glued
    numbers shown as values, no news pop-up, and --allow-root when run as root."""
    sys.path.insert(0, str(ROOT / "tools"))
    import lab_glue

    options, lab_env = lab_glue.reader_lab(BUILD / "lab")
    env = dict(os.environ, **lab_env,
               PYTHONPATH=os.pathsep.join(filter(None, [str(ROOT / "tools"), os.environ.get("PYTHONPATH")])))
    run(BIN / "jupyter", "lab", *options, *args, cwd=BOOK, env=env)


COMMANDS = {
    "build": build,
    "test": test,
    "browser-test": browser_test,
    "pdf": pdf,
    "notebooks": notebooks,
    "lab": lab,
    "bench": bench,
    "knife-edge": knife_edge,
    "study": study,
}


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
