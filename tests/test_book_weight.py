"""tools/book_weight.py (issue 45): the lighter HTML book shows the same pixels in fewer bytes."""

from __future__ import annotations

import base64
import importlib.util
import io
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import pytest
from matplotlib.animation import FuncAnimation
from PIL import Image

TOOL = Path(__file__).resolve().parents[1] / "tools" / "book_weight.py"
spec = importlib.util.spec_from_file_location("book_weight", TOOL)
book_weight = importlib.util.module_from_spec(spec)
spec.loader.exec_module(book_weight)


def figure_png(transparent: bool = False, dpi: int = 100) -> bytes:
    """A small figure like the book's: antialiased lines, text, a legend."""
    fig, ax = plt.subplots(figsize=(4, 3))
    x = np.linspace(0, 6, 200)
    ax.plot(x, np.sin(x), label="sine")
    ax.plot(x, np.cos(x), label="cosine")
    ax.set_xlabel("time (s)")
    ax.legend()
    out = io.BytesIO()
    fig.savefig(out, format="png", dpi=dpi, transparent=transparent)
    plt.close(fig)
    return out.getvalue()


def pixels(data: bytes) -> np.ndarray:
    image = Image.open(io.BytesIO(data))
    image.load()
    return np.asarray(image.convert("RGBA"), dtype=int)


@pytest.mark.parametrize("transparent", [False, True])
def test_the_stored_file_shows_the_figures_pixels(transparent):
    original = figure_png(transparent)
    content, ext = book_weight.smallest_faithful_file(original)
    png = book_weight.smallest_exact_png(original)
    # the file is the re-compressed PNG's very pixels (lossless WebP, or that PNG itself) ...
    assert np.array_equal(pixels(content), pixels(png))
    # ... which change no channel of the figure by more than MAX_CHANNEL_ERROR levels
    assert np.abs(pixels(content) - pixels(original)).max() <= book_weight.MAX_CHANNEL_ERROR
    assert Image.open(io.BytesIO(content)).format == {"webp": "WEBP", "png": "PNG"}[ext]


def test_webp_only_where_it_is_smaller():
    for original in (figure_png(), figure_png(transparent=True), figure_png(dpi=30)):
        content, ext = book_weight.smallest_faithful_file(original)
        png = book_weight.smallest_exact_png(original)
        assert len(content) <= len(png)
        if ext == "png":
            assert content == png
    # a line drawing: lossless WebP is smaller than the best PNG (the reason for the format)
    content, ext = book_weight.smallest_faithful_file(figure_png())
    assert ext == "webp" and len(content) < 0.9 * len(book_weight.smallest_exact_png(figure_png()))


def test_pages_link_files_and_notebooks_keep_png(tmp_path):
    images = book_weight.InlineImages(tmp_path)
    encoded = base64.b64encode(figure_png()).decode()
    page = tmp_path / "book" / "chapter.html"
    page.parent.mkdir()
    page.write_text(f'<img src="data:image/png;base64,{encoded}"><img src="data:image/png;base64,{encoded}">',
                    encoding="utf-8")
    images.rewrite(page)
    text = page.read_text(encoding="utf-8")
    assert "data:image" not in text
    files = list((tmp_path / book_weight.FOLDER).iterdir())
    assert len(files) == 1 and text.count(f"../_images/inline/{files[0].name}") == 2  # a figure stored once
    # the notebook's copy is a PNG with the same pixels as the book's file
    png = base64.b64decode(images.recompressed(encoded, inline=False))
    assert Image.open(io.BytesIO(png)).format == "PNG"
    assert np.array_equal(pixels(png), pixels(files[0].read_bytes()))
    # a figure no page links goes; a linked one stays
    (tmp_path / book_weight.FOLDER / "0123456789abcdef0123.webp").write_bytes(b"unlinked")
    (tmp_path / "_static").mkdir()
    book_weight.collect_unused(tmp_path)
    assert [f.name for f in (tmp_path / book_weight.FOLDER).iterdir()] == [files[0].name]


def test_a_downloaded_animation_keeps_its_first_frame(tmp_path):
    fig, ax = plt.subplots(figsize=(2, 2))
    (line,) = ax.plot([0, 1], [0, 0])
    animation = FuncAnimation(fig, lambda k: line.set_ydata([k, -k]), frames=4)
    markup = animation.to_jshtml(fps=4)
    plt.close(fig)
    first = base64.b64decode(book_weight.DATA_URI.findall(markup)[0].replace("\\\n", ""))
    notebook = {"cells": [{"cell_type": "code", "outputs": [
        {"output_type": "display_data", "data": {"text/html": markup, "text/plain": "<HTML>"}}]}]}
    images = book_weight.InlineImages(tmp_path)
    lighter = book_weight.lighter_notebook(notebook, images)["cells"][0]["outputs"][0]["data"]
    kept = book_weight.DATA_URI.findall(lighter["text/html"])
    assert len(kept) == 1 and "run the cell" in lighter["text/html"]
    assert len(lighter["text/html"]) < len(markup) / 2
    assert np.abs(pixels(base64.b64decode(kept[0])) - pixels(first)).max() <= book_weight.MAX_CHANNEL_ERROR
