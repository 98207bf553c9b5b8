"""tools/execute_notebooks.py: an unchanged source executes to a byte-identical stored notebook."""

import importlib.util
from pathlib import Path

TOOL = Path(__file__).resolve().parents[1] / "tools" / "execute_notebooks.py"
SOURCE = '''# %%
import uuid

print(uuid.uuid4().hex)  # what widget and animation ids are made of
'''


def load_tool():
    spec = importlib.util.spec_from_file_location("execute_notebooks", TOOL)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_re_executing_an_unchanged_source_stores_the_same_bytes(tmp_path):
    tool = load_tool()
    source = tmp_path / "ids.py"
    source.write_text(SOURCE)
    tool.execute(source)
    first = source.with_suffix(".ipynb").read_bytes()
    tool.execute(source)
    assert source.with_suffix(".ipynb").read_bytes() == first
    assert b"uuid4" in first and first.count(b"\\n") >= 1


def test_streams_are_stored_merged_whatever_the_kernel_cut():
    """Where a printed text is cut into messages depends on timing: stored, consecutive pieces are one."""
    import nbformat

    coalesce = load_tool().coalesce_streams
    out = nbformat.v4.new_output
    outputs = [out("stream", name="stdout", text="a\n"), out("stream", name="stdout", text="b\n"),
               out("stream", name="stderr", text="w\n"), out("display_data", data={"text/plain": "x"}),
               out("stream", name="stdout", text="c\n"), out("stream", name="stdout", text="d")]
    merged = coalesce(outputs)
    assert [(o["output_type"], o.get("name"), o.get("text")) for o in merged] == [
        ("stream", "stdout", "a\nb\n"), ("stream", "stderr", "w\n"), ("display_data", None, None),
        ("stream", "stdout", "c\nd")]


def test_the_kernels_do_without_the_iri_grammar_and_glue_still_works():
    """NO_IRI_GRAMMAR (the startup of the book's kernels and the tests'): nbformat, imported by
    myst-nb's glue, loads without rfc3987-syntax and still validates a notebook."""
    import subprocess
    import sys

    check = load_tool().NO_IRI_GRAMMAR + (
        "import nbformat, sys\n"
        "nbformat.validate(nbformat.v4.new_notebook(cells=[nbformat.v4.new_code_cell('1')]))\n"
        "from myst_nb.ext.glue import glue\n"
        "assert sys.modules['rfc3987_syntax'] is None\n")
    subprocess.run([sys.executable, "-c", check], check=True, timeout=60)
