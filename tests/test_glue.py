"""Values glued into the prose (myst-nb `glue`) render as numbers, once each.

A NumPy scalar glued as it is stores `np.float64(0.05)` as its text, which a `{glue:text}` role
with a format cannot read (the build fails) and which a role without one prints as it is.
"""

import json
from pathlib import Path

import pytest

NOTEBOOKS = sorted((Path(__file__).resolve().parents[1] / "book").rglob("*.ipynb"))


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_glued_values_are_plain_and_unique(path):
    names = []
    for cell in json.loads(path.read_text())["cells"]:
        for output in cell.get("outputs", []):
            name = output.get("metadata", {}).get("scrapbook", {}).get("name")
            if name is None:
                continue
            names.append(name)
            data = output.get("data", {})  # display=False glue: "application/papermill.record/text/plain"
            text = next((v for k, v in data.items() if k.endswith("text/plain")), "")
            text = text if isinstance(text, str) else "".join(text)
            assert not text.startswith("np."), f"{path.name}: glue {name!r} is a NumPy scalar ({text}); glue float(x)"
    duplicates = sorted({n for n in names if names.count(n) > 1})
    assert not duplicates, f"{path.name}: glued twice: {duplicates}"
