"""Stored notebook outputs hold nothing of the machine that made them.

A warning printed with the path of a library file (``/home/x/.venv/lib/...``) is compared by
strict nbval, so a clone anywhere else fails on it.
"""

import json
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = sorted((ROOT / "book").rglob("*.ipynb"))


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_no_absolute_path_of_this_checkout_in_outputs(path):
    for index, cell in enumerate(json.loads(path.read_text())["cells"]):
        text = json.dumps(cell.get("outputs", []))
        assert str(ROOT) not in text and "site-packages" not in text, f"{path.name} cell {index}"
