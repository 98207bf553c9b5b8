"""tools/perturbed_arithmetic.py imitates another CPU: a last-bit change of NumPy's functions."""

import importlib.util
import subprocess
import sys
from pathlib import Path

import nbformat

ROOT = Path(__file__).resolve().parents[1]
spec = importlib.util.spec_from_file_location("perturbed_arithmetic", ROOT / "tools" / "perturbed_arithmetic.py")
tool = importlib.util.module_from_spec(spec)
spec.loader.exec_module(tool)

CHECK = tool.PERTURB_NUMPY + r"""
x = _np.random.default_rng(0).uniform(-30, 30, 200_000)
exact, moved = _np.exp.__wrapped__(x), _np.exp(x)
ulps = (moved.view(_np.int64) - exact.view(_np.int64))
print(float(_np.mean(ulps != 0)), int(ulps.min()), int(ulps.max()), _np.exp(x[:5]).tolist() == _np.exp(x[:5]).tolist())
"""


def test_one_input_in_sixteen_moves_by_one_ulp_deterministically():
    out = subprocess.run([sys.executable, "-c", CHECK], capture_output=True, text=True, check=True).stdout.split()
    share, low, high, repeatable = float(out[0]), int(out[1]), int(out[2]), out[3]
    # a hash of the input bits picks 1/16 of them: binomial sd over 2e5 draws is about 0.0005
    assert abs(share - 1 / 16) < 0.003
    assert (low, high) == (0, 1) and repeatable == "True"


def test_glued_values_and_text_outputs_are_read_apart():
    nb = nbformat.v4.new_notebook()
    cell = nbformat.v4.new_code_cell("x")
    cell.outputs = [
        nbformat.v4.new_output("stream", name="stdout", text="95 of 100\n"),
        nbformat.v4.new_output("display_data", data={"application/papermill.record/text/plain": "95"},
                               metadata={"scrapbook": {"name": "count"}}),
    ]
    nb.cells.append(cell)
    assert tool.text_outputs(nb) == [(0, "95 of 100\n")]
    assert tool.glued(nb) == {"count": "95"}


def test_a_glued_value_is_compared_as_the_prose_shows_it():
    nb = nbformat.v4.new_notebook()
    nb.cells.append(nbformat.v4.new_markdown_cell("ratio {glue:text}`ratio:.2f`, raw {glue}`raw`"))
    assert tool.glue_formats(nb) == {"ratio": {".2f"}, "raw": {""}}
    assert tool.shown("0.6156128575783213", ".2f") == tool.shown("0.6156128575783215", ".2f") == "0.62"
    assert tool.shown("0.6156128575783213", "") != tool.shown("0.6156128575783215", "")
