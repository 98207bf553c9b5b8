"""Sphinx extension of the book: a lighter HTML book (issue 45).

Loaded through ``sphinx: local_extensions`` in ``_config.yml``; it acts when the HTML builder has
finished. A chapter's figures come out of its notebook as inline images (``data:`` URIs, base64:
a third larger than the file, and loaded with the page even when a panel never shows them), each
figure with its phone copy. Here, in every page of the built book:

- each inline PNG becomes a file ``_images/inline/<digest>.webp`` (or ``.png``), named by its content
  (a figure shown twice is stored once), and the page links it; the panels' figure lists
  (``pfcourse-panels.js`` sets an image's ``src`` from them) link their files the same way, so a
  panel's other settings load only when the reader picks them;
- each such PNG is stored as small as it stays faithful: re-compressed, and as an adaptive
  256-colour palette when that changes no pixel by more than ``MAX_CHANNEL_ERROR`` levels out of
  255 in any channel (antialiased text and lines keep their shape), else as it was; then as
  lossless WebP (the same pixels; Chromium, Firefox and Safari show it) when that is smaller;
- figures no page links any more (an incremental build's leftovers) and the theme's source maps go;
- the notebooks offered for download (``_sources/``) keep each figure once: the phone copy of a
  figure (``<picture class="pfcourse-figure">``, beside the figure's own ``image/png``) goes, a
  panel keeps only the figure it opens with and an animation its first frame (running the cell
  brings the live panel or the animation back), and every PNG is the re-compressed one (a
  notebook keeps PNG: ``image/png`` is what Jupyter and the PDF build read).
"""

from __future__ import annotations

import base64
import hashlib
import io
import json
import os
import re
from pathlib import Path
from typing import Any

import numpy as np
from PIL import Image

#: An inline PNG; in an animation's script its base64 is broken into lines (a backslash ending each).
DATA_URI = re.compile(r"data:image/png;base64,([A-Za-z0-9+/=]+(?:\\\n[A-Za-z0-9+/=]+)*)")
#: Largest change of a channel (0-255) an adaptive palette may make to any pixel of a figure.
MAX_CHANNEL_ERROR = 8
FOLDER = "_images/inline"
#: Pillow's lossless WebP settings (``quality`` is the encoder's effort in lossless mode). On a sample of
#: the book's figures, 50 at method 3 came within 1 % of 100 at method 4 in under half its time; method 6
#: saved another 1 % in about forty times the time.
WEBP_OPTIONS = {"lossless": True, "quality": 50, "method": 3, "exact": True}
PANEL_DATA = re.compile(r'(<script type="application/json" class="pfcourse-panel-data">)(.*?)(</script>)', re.S)


def smallest_exact_png(data: bytes) -> bytes:
    """The PNG ``data`` stored as small as :data:`MAX_CHANNEL_ERROR` allows (see the module docstring).

    A figure drawn on an opaque background is quantized as RGB by maximum coverage (on the book's
    figures it keeps every channel within a few levels where the octree method, the only one
    Pillow offers for RGBA, moves antialiased edges by up to thirty).
    """
    image = Image.open(io.BytesIO(data))
    image.load()
    rgba = np.asarray(image.convert("RGBA"))
    candidates = [data]
    if (rgba[..., 3] == 255).all():
        rgb = image.convert("RGB")
        paletted = rgb.quantize(colors=256, method=Image.Quantize.MAXCOVERAGE, dither=Image.Dither.NONE)
        error = np.abs(np.asarray(paletted.convert("RGB"), dtype=int) - rgba[..., :3]).max()
        if error <= MAX_CHANNEL_ERROR:
            out = io.BytesIO()
            paletted.save(out, format="PNG", optimize=True)
            candidates.append(out.getvalue())
    out = io.BytesIO()
    image.save(out, format="PNG", optimize=True)
    candidates.append(out.getvalue())
    return min(candidates, key=len)


def smallest_faithful_file(data: bytes) -> tuple[bytes, str]:
    """(file, extension) for the PNG ``data`` in the HTML book: :func:`smallest_exact_png`, or its very
    pixels as lossless WebP (``exact``: even fully transparent pixels keep their colour) when smaller."""
    png = smallest_exact_png(data)
    image = Image.open(io.BytesIO(png))
    image.load()
    if image.mode not in ("RGB", "RGBA"):
        image = image.convert("RGBA" if "transparency" in image.info or "A" in image.mode else "RGB")
    out = io.BytesIO()
    image.save(out, format="WEBP", **WEBP_OPTIONS)
    webp = out.getvalue()
    return (webp, "webp") if len(webp) < len(png) else (png, "png")


class InlineImages:
    """Writes each inline PNG once under ``outdir/_images/inline`` and gives its path."""

    def __init__(self, outdir: Path) -> None:
        self.outdir = outdir
        self.folder = outdir / FOLDER
        self.folder.mkdir(parents=True, exist_ok=True)
        self.known: dict[str, str] = {}
        self.pngs: dict[str, bytes] = {}

    def file_for(self, encoded: str) -> Path:
        key = hashlib.sha256(encoded.encode()).hexdigest()
        if key not in self.known:
            data = base64.b64decode(encoded.replace("\\\n", ""))
            stem = hashlib.sha256(data).hexdigest()[:20]
            stored = [path for ext in ("webp", "png") if (path := self.folder / f"{stem}.{ext}").exists()]
            if stored:
                path = stored[0]
            else:
                content, ext = smallest_faithful_file(data)
                path = self.folder / f"{stem}.{ext}"
                path.write_bytes(content)
            self.known[key] = path.name
        return self.folder / self.known[key]

    def png_for(self, encoded: str) -> bytes:
        """The re-compressed PNG of ``encoded`` (for a notebook), the same pixels as its file in the book."""
        key = hashlib.sha256(encoded.encode()).hexdigest()
        if key not in self.pngs:
            data = base64.b64decode(encoded.replace("\\\n", ""))
            stem = hashlib.sha256(data).hexdigest()[:20]
            png = self.folder / f"{stem}.png"
            # the book's WebP file holds the pixels of smallest_exact_png(data) (deterministic), which a
            # notebook keeps as PNG; a figure no page shows gets no file
            self.pngs[key] = png.read_bytes() if png.exists() else smallest_exact_png(data)
        return self.pngs[key]

    def recompressed(self, text: str, inline: bool) -> str:
        """``text`` (HTML with inline PNGs, or one PNG's base64) with each PNG re-compressed as in the book."""
        def again(encoded: str) -> str:
            return base64.b64encode(self.png_for(encoded)).decode()

        if not inline:
            return again(text.strip())
        return DATA_URI.sub(lambda m: "data:image/png;base64," + again(m.group(1)), text)

    def rewrite(self, page: Path) -> None:
        text = page.read_text(encoding="utf-8")
        if "data:image/png;base64," not in text:
            return
        here = page.parent

        def link(match: re.Match) -> str:
            return os.path.relpath(self.file_for(match.group(1)), here).replace(os.sep, "/")

        page.write_text(DATA_URI.sub(link, text), encoding="utf-8")


def lighter_notebook(notebook: dict, images: InlineImages) -> dict:
    """A notebook to download: each figure once, each PNG as small as it stays exact.

    A figure's phone copy (``<picture>`` beside its ``image/png``) goes; a panel keeps the figure it
    opens with (its live widget comes back when the cell runs), not its grid of figures; an
    animation (matplotlib's ``to_jshtml``: every frame inline) keeps its first frame.
    """
    for cell in notebook.get("cells", []):
        for output in cell.get("outputs", []):
            data = output.get("data", {})
            markup = "".join(data.get("text/html", ""))
            if markup.startswith('<picture class="pfcourse-figure">') and "image/png" in data:
                del data["text/html"]
            elif 'class="pfcourse-panel"' in markup:
                opening = re.search(r'<img class="pfcourse-panel-figure"[^>]*>', markup)
                data["text/html"] = ('<div class="pfcourse-panel-opening">' + (opening.group(0) if opening else "")
                                     + "<p>The panel's figure at the settings it opens with: run the cell for the "
                                     "live panel.</p></div>")
            elif '<div class="animation">' in markup:
                first = DATA_URI.search(markup)
                data["text/html"] = ('<div class="pfcourse-animation-opening">'
                                     + (f'<img src="{first.group(0)}" alt="first frame">' if first else "")
                                     + "<p>The animation's first frame: run the cell to play it.</p></div>")
            for key in ("text/html", "image/png"):
                if key in data:
                    data[key] = images.recompressed("".join(data[key]) if key == "text/html" else data[key],
                                                    inline=key == "text/html")
    return notebook


def collect_unused(outdir: Path) -> None:
    """Delete the inline figures no page links any more (an incremental build leaves the old ones), and
    the theme's source maps (``*.map``: read only by a browser's developer tools)."""
    linked = set()
    for page in outdir.rglob("*.html"):
        linked.update(re.findall(r"_images/inline/([0-9a-f]+\.(?:png|webp))", page.read_text(encoding="utf-8")))
    for image in (outdir / FOLDER).iterdir():
        if image.suffix in (".png", ".webp") and image.name not in linked:
            image.unlink()
    for source_map in (outdir / "_static").rglob("*.map"):
        source_map.unlink()


def lighten(app, exception) -> None:
    if exception is not None or app.builder.format != "html":
        return
    outdir = Path(app.outdir)
    images = InlineImages(outdir)
    for page in sorted(outdir.rglob("*.html")):
        if "_static" not in page.relative_to(outdir).parts:
            images.rewrite(page)
    for notebook in sorted((outdir / "_sources").rglob("*.ipynb")):
        content = json.loads(notebook.read_text(encoding="utf-8"))
        notebook.write_text(json.dumps(lighter_notebook(content, images), indent=1, ensure_ascii=False) + "\n",
                            encoding="utf-8")
    collect_unused(outdir)


def setup(app) -> dict[str, Any]:
    app.connect("build-finished", lighten)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
