"""Which stored outputs would a last-bit change of the arithmetic flip? Execute and compare.

    python3 tasks.py knife-edge [book/partN/X.py ...]    (default: every chapter)

Another CPU can round a few results differently in the last bit (NumPy's AVX-512 ``exp`` and
``sin`` on about 5 % of inputs, OpenBLAS's SkylakeX kernels; see pfcourse/arithmetic.py). This
tool imitates that on any machine: it executes each notebook in memory, without storing it, in
a kernel where

* OpenBLAS uses its Sandybridge (AVX) kernels instead of the pinned Haswell ones, and
* NumPy's transcendental functions (exp, log, expm1, log1p, sin, cos, tan, arctan2, arctan,
  sqrt is left exact) return the next float up for about one input in sixteen, chosen by a
  hash of the input's bits,

then compares every text output with the stored notebook and lists the cells that differ.
An output that changes is decided by a last-bit accident (a count on a threshold at working
precision, a statistic of a chaotic filter): the prose must not quote it as it is. Glued values
(myst-nb ``glue``) are compared separately, as the prose shows them (formatted with the format
spec of each ``{glue:text}`` role that quotes them): none of them may change. Exit status 1
when a quoted glued value changes.
"""

from __future__ import annotations

import difflib
import importlib.util
import json
import os
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

# The last-bit change of NumPy's transcendental functions, run after `import numpy as _np`
# (also by tools/simulated_avx512/sitecustomize.py, which imitates an AVX-512 CPU's NumPy).
PERTURB_FUNCTIONS = r'''
import numba as _numba

_numba.njit(lambda x: _np.exp(x))(1.0)  # numba registers NumPy's real ufuncs at its first compile

def _last_bit_perturbed(ufunc):
    def wrapped(*args, **kwargs):
        out = ufunc(*args, **kwargs)
        x = _np.asarray(args[0]) if args else None
        if isinstance(out, _np.ndarray) and out.dtype == _np.float64 and x is not None \
                and x.dtype == _np.float64 and x.shape == out.shape and out.size:
            pick = ((x.view(_np.uint64) * _np.uint64(0x9E3779B97F4A7C15)) >> _np.uint64(60)) == 0
            out[pick] = _np.nextafter(out[pick], _np.inf)
        elif isinstance(out, _np.float64) and x is not None and x.dtype == _np.float64 and x.ndim == 0:
            if ((int(x.view(_np.uint64)) * 0x9E3779B97F4A7C15) % 2**64) >> 60 == 0:
                out = _np.nextafter(out, _np.inf)
        return out
    wrapped.__name__ = ufunc.__name__
    wrapped.__wrapped__ = ufunc
    return wrapped

for _name in ("exp", "log", "expm1", "log1p", "sin", "cos", "tan", "arctan2", "arctan"):
    setattr(_np, _name, _last_bit_perturbed(getattr(_np, _name)))
'''

# The knife-edge kernels' startup: unpinned on purpose, so pfcourse's warning is not wanted.
PERTURB_NUMPY = r'''
import warnings as _warnings

_warnings.filterwarnings("ignore", message="pfcourse: NumPy was started")  # meant: unpinned here
import numpy as _np
''' + PERTURB_FUNCTIONS


def load_executor():
    spec = importlib.util.spec_from_file_location("execute_notebooks", ROOT / "tools" / "execute_notebooks.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def text_outputs(notebook) -> list[tuple[int, str]]:
    """(cell index, text) of every code cell's text outputs, glue outputs excluded."""
    rows = []
    for index, cell in enumerate(notebook["cells"]):
        if cell["cell_type"] != "code":
            continue
        parts = []
        for output in cell.get("outputs", []):
            if output.get("metadata", {}).get("scrapbook"):
                continue
            if output["output_type"] == "stream":
                parts.append(output["text"] if isinstance(output["text"], str) else "".join(output["text"]))
            elif "data" in output and "text/plain" in output["data"]:
                text = output["data"]["text/plain"]
                parts.append(text if isinstance(text, str) else "".join(text))
            elif output["output_type"] == "error":
                parts.append(f"{output['ename']}: {output['evalue']}")
        rows.append((index, "".join(parts)))
    return rows


def glued(notebook) -> dict[str, str]:
    values = {}
    for cell in notebook["cells"]:
        for output in cell.get("outputs", []):
            name = output.get("metadata", {}).get("scrapbook", {}).get("name")
            if name:
                data = output.get("data", {})  # display=False: "application/papermill.record/text/plain"
                text = next((v for k, v in data.items() if k.endswith("text/plain")), "")
                values[name] = text if isinstance(text, str) else "".join(text)
    return values


GLUE_ROLE = re.compile(r"\{glue(?::text)?\}`([A-Za-z0-9_]+)(?::([^`]*))?`")


def glue_formats(notebook) -> dict[str, set]:
    """How the prose shows each glued value: the format specs of its roles ('' for none)."""
    formats: dict[str, set] = {}
    for cell in notebook["cells"]:
        if cell["cell_type"] == "markdown":
            source = cell["source"] if isinstance(cell["source"], str) else "".join(cell["source"])
            for name, spec in GLUE_ROLE.findall(source):
                formats.setdefault(name, set()).add(spec)
    return formats


def shown(text: str, spec: str) -> str:
    """The text the prose shows for a glued value's stored text and a role's format spec."""
    if not spec:
        return text
    try:
        return format(float(text), spec)
    except ValueError:
        return text


def ignored(cell) -> bool:
    tags = cell.get("metadata", {}).get("tags", [])
    return "nbval-ignore-output" in tags or "nbval-skip" in tags


def compare(source: Path, executor) -> tuple[int, int]:
    stored = json.loads(source.with_suffix(".ipynb").read_text())
    fresh = executor.execute(source, extra_startup=PERTURB_NUMPY, store=False)
    changed_cells = 0
    for (index, old), (_, new) in zip(text_outputs(stored), text_outputs(fresh)):
        if old != new and not ignored(stored["cells"][index]):
            changed_cells += 1
            print(f"--- {source.relative_to(ROOT)} cell {index}: output changes")
            diff = difflib.unified_diff(old.splitlines(), new.splitlines(), "stored", "perturbed", lineterm="", n=0)
            print("\n".join(list(diff)[2:40]))
    # A glued value counts as changed when the prose would show it differently: formatted with
    # each format spec its roles use (a value no role quotes is not checked).
    old_glue, new_glue, formats = glued(stored), glued(fresh), glue_formats(stored)
    changed_glue = sorted(
        k for k in formats
        if any(shown(old_glue.get(k, ""), spec) != shown(new_glue.get(k, ""), spec) for spec in formats[k])
    )
    for name in changed_glue:
        print(f"!!! {source.relative_to(ROOT)} glue {name!r}: {old_glue.get(name)!r} -> {new_glue.get(name)!r}")
    return changed_cells, len(changed_glue)


def main(argv: list[str]) -> int:
    os.environ["OPENBLAS_CORETYPE"] = "Sandybridge"  # another kernel family than the pinned one
    sources = [Path(a).resolve() for a in argv] or sorted((ROOT / "book").rglob("*.py"))
    executor = load_executor()
    total_cells = total_glue = 0
    for source in sources:
        cells, glue = compare(source, executor)
        total_cells += cells
        total_glue += glue
    print(f"\n{total_cells} cell output(s) and {total_glue} glued value(s) changed under a last-bit perturbation")
    return 1 if total_glue else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
