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
