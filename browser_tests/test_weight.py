"""The built book's weight (issue 45): under 50 MB in all, no page over 2 MB.

A page's weight is its HTML document plus the images it shows when opened on a desktop (its
``<img src>``: a phone loads the figures' smaller narrow copies instead); the book's shared assets
(``_static/``: MathJax, the theme, the widget manager) are loaded once for every page and counted in
the book's total. A panel's other figures are files loaded only when the reader moves a control
(``tools/book_weight.py`` turns inline images into files, lossless WebP where smaller), so they count in
the total, not the page.
"""

from __future__ import annotations

import re
from pathlib import Path
from urllib.parse import unquote

import pytest

from conftest import HTML, book_pages

MAX_BOOK_MB = 50.0  # 60 for a day (2026-11-27); lossless WebP figures and downloads without animation frames
MAX_PAGE_MB = 2.0
MB = 1e6


def page_weight(page: str) -> tuple[int, int]:
    """(bytes of the HTML document, bytes of the images it shows on opening)."""
    path = HTML / page
    text = path.read_text(encoding="utf-8")
    images = 0
    for source in set(re.findall(r'<img\b[^>]*\bsrc="([^"]+)"', text)):
        if source.startswith("data:"):
            images += len(source) * 3 // 4
        elif not source.startswith(("http:", "https:")):
            target = (path.parent / unquote(source.split("#")[0])).resolve()
            images += target.stat().st_size if target.is_file() else 0
    return path.stat().st_size, images


def test_the_book_is_under_its_budget():
    total = sum(p.stat().st_size for p in HTML.rglob("*") if p.is_file())
    largest = sorted(((p.stat().st_size, p.relative_to(HTML).as_posix()) for p in HTML.rglob("*") if p.is_file()),
                     reverse=True)[:5]
    assert total <= MAX_BOOK_MB * MB, (f"the built book is {total / MB:.1f} MB (at most {MAX_BOOK_MB:.0f}); "
                                      f"largest files: {largest}")


@pytest.mark.parametrize("page", book_pages())
def test_no_page_weighs_over_two_megabytes(page):
    document, images = page_weight(page)
    assert document + images <= MAX_PAGE_MB * MB, (
        f"{page} weighs {(document + images) / MB:.2f} MB: document {document / MB:.2f} MB, "
        f"images shown on opening {images / MB:.2f} MB (at most {MAX_PAGE_MB:.0f} MB)")


def test_no_page_carries_its_figures_inline():
    inline = [page for page in book_pages() if "data:image/png;base64," in (HTML / page).read_text(encoding="utf-8")]
    assert not inline, f"pages with inline figures (tools/book_weight.py turns them into files): {inline}"


def test_every_figure_file_a_page_names_is_there():
    """Figures, phone copies, panel frames and animation frames are files (PNG or lossless WebP): each one
    a page names (in an ``<img>``, a ``<source>``, a panel's data or an animation's script) exists."""
    missing = []
    for page in book_pages():
        text = (HTML / page).read_text(encoding="utf-8")
        for name in set(re.findall(r"_images/inline/([0-9a-f]+\.(?:png|webp))", text)):
            if not (HTML / "_images" / "inline" / name).is_file():
                missing.append(f"{page}: {name}")
    assert not missing, f"{len(missing)} figure file(s) missing: {missing[:5]}"
