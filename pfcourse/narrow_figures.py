"""A narrow copy of a wide figure, for the HTML book read on a phone.

The HTML book shows a figure at most as wide as its text column: 688 CSS px in a 1280 px
window, :data:`PHONE_COLUMN_PX` (388 px) in a 420 px one. A figure whose tight PNG is ``W``
pixels wide and whose smallest text is ``s`` pixels shows that text at
``s min(1, C / W)`` pixels in a column of ``C`` pixels; on a phone a 1000 px study figure
would show its 9 pt (12.5 px) text at 4.9 px. Below :data:`MIN_TEXT_PX` (8 px), the figure
needs another layout, which :func:`narrow_layout` makes from the figure itself:

* its axes that sit side by side (columns of its grid) are stacked in one column, in reading
  order (row by row), each as wide as the phone's column; an axes sharing its neighbour's
  y axis gets its tick labels back;
* the figure is :data:`PHONE_WIDTH_IN` inches wide, so its text keeps its natural size;
* a legend placed right of its axes (``bbox_to_anchor=(1.02, 1)``) goes under it, a
  figure legend under the figure, in at most two columns; long titles wrap;
* margins are set by hand (:data:`MARGINS_IN`), so the copy costs one drawing.

:func:`install` adds a display formatter to IPython: each figure shown in a notebook is stored
as its usual ``image/png`` and, when it needs the narrow copy, also as ``text/html``: a
``<picture>`` whose ``<source>`` serves the narrow PNG to windows up to :data:`NARROW_MEDIA`
and whose ``<img>`` is the usual PNG (the HTML book prefers ``text/html``; JupyterLab shows
either). The figure itself is not changed: the narrow layout is made on a copy.  Figures
that stay readable when scaled to the phone's column get no copy (no cost, no weight).
"""

from __future__ import annotations

import base64
import contextlib
import html
import io
import pickle
import struct
import warnings

import matplotlib as mpl
import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.gridspec import GridSpec
from matplotlib.text import Text
from matplotlib.transforms import ScaledTranslation
from PIL import Image

#: The HTML book's text column in a 420 px window (a phone), in CSS px (measured in chromium).
PHONE_COLUMN_PX = 388.0
#: The smallest text a reader should have to read in a figure, in CSS px.
MIN_TEXT_PX = 8.0
#: Width of the narrow copy in inches (at the book's 100 dpi, 375 px: the column less a margin).
PHONE_WIDTH_IN = 3.75
#: Height of one stacked panel of the narrow copy, in inches (within these bounds of the original's).
PANEL_HEIGHT_IN = (2.4, 3.2)
#: The windows that are served the narrow copy (the book's narrow-screen style starts there too).
NARROW_MEDIA = "(max-width: 760px)"
#: What :func:`install` adds to IPython's display formatters, so that it is added once.
_INSTALLED: dict = {}
#: Whether figures shown now get a narrow copy (see :func:`without_narrow_copies`).
_ENABLED = [True]


@contextlib.contextmanager
def without_narrow_copies():
    """Within the block, figures are shown without a narrow copy (a live panel's redraw: the page
    has its own copies, and the redraw stays as fast as before)."""
    _ENABLED.append(False)
    try:
        yield
    finally:
        _ENABLED.pop()


def png_width(png: bytes) -> int:
    """Width in pixels of a PNG, read from its header."""
    return struct.unpack(">I", png[16:20])[0]


def smallest_font_px(figure: Figure, dpi: float) -> float:
    """Size in pixels (at ``dpi``) of the smallest visible, non-empty text of ``figure`` (no drawing)."""
    sizes = [t.get_fontsize() for t in figure.findobj(Text) if t.get_visible() and t.get_text().strip()]
    return min(sizes, default=mpl.rcParams["font.size"]) * dpi / 72.0


def needs_narrow_copy(width_px: float, smallest_px: float, column_px: float = PHONE_COLUMN_PX) -> bool:
    """Whether a figure ``width_px`` wide, whose smallest text is ``smallest_px``, is too small to
    read scaled to the phone's column: ``smallest_px min(1, column_px / width_px) < MIN_TEXT_PX``."""
    return smallest_px * min(1.0, column_px / width_px) < MIN_TEXT_PX


def _stack_axes(figure: Figure, grid: GridSpec) -> int:
    """Put the figure's grid of axes in ``grid``'s one column, row by row; returns the number of panels.

    Axes of one top-level grid are moved (a colour bar made beside its axes, in a grid nested in
    the axes' cell, moves with it); axes outside a grid (insets, hand-placed) stay where they are
    relative to the figure.
    """
    for number, axes_in_cell in enumerate(_cells(figure)):
        for axes in axes_in_cell:
            spec = axes.get_subplotspec()
            top = spec.get_topmost_subplotspec()
            if spec is top:
                axes.set_subplotspec(grid[number, 0])
            else:  # in a grid nested in the cell (e.g. a colour bar's): move the nested grid
                nested = spec.get_gridspec()
                while nested._subplot_spec is not top:
                    nested = nested._subplot_spec.get_gridspec()
                nested._subplot_spec = grid[number, 0]
            if top.colspan.start > 0 and axes.get_shared_y_axes().get_siblings(axes)[1:]:
                axes.yaxis.set_tick_params(labelleft=True)  # its neighbour's labels are no longer beside it
    for axes in figure.axes:
        if axes.get_subplotspec() is not None:
            axes._set_position(axes.get_subplotspec().get_position(figure))
    return len(_cells(figure))


def _cells(figure: Figure) -> list[list]:
    """The figure's axes grouped by the cell of its one top-level grid they sit in, row by row
    (empty when the axes are not in exactly one grid)."""
    cells: dict[tuple[int, int], list] = {}
    grids = set()
    for axes in figure.axes:
        spec = axes.get_subplotspec()
        if spec is None:
            continue
        top = spec.get_topmost_subplotspec()
        grids.add(id(top.get_gridspec()))
        cells.setdefault((top.rowspan.start, top.colspan.start), []).append(axes)
    return [cells[key] for key in sorted(cells)] if len(grids) == 1 else []


def _legends_under(figure: Figure) -> tuple[float, float]:
    """Move legends that sit right of their axes under them, and figure legends under the figure.

    Returns the heights (inches) to leave under an axes and under the figure for them.
    """
    below = ScaledTranslation(0, -0.55, figure.dpi_scale_trans)  # under the tick labels and axis label
    under_axes = under_figure = 0.0
    for axes in figure.axes:
        legend = axes.get_legend()
        if legend is None:
            continue
        anchor = legend.get_bbox_to_anchor().transformed(axes.transAxes.inverted())
        if anchor.x0 >= 0.99:  # anchored at or past the right edge: outside the axes
            legend.set_bbox_to_anchor((0.5, 0.0), transform=axes.transAxes + below)
            legend.set_loc("upper center")
            legend._ncols = min(2, len(legend.get_texts()))
            under_axes = max(under_axes, _legend_height(legend))
    for legend in figure.legends:
        legend.set_bbox_to_anchor((0.5, 0.0), transform=figure.transFigure)
        legend.set_loc("lower center")
        legend._ncols = min(2, len(legend.get_texts()))
        under_figure += _legend_height(legend)
    return under_axes, under_figure


def _legend_height(legend) -> float:
    """Inches a legend of ``legend._ncols`` columns takes (its rows of text and a margin)."""
    rows = -(-len(legend.get_texts()) // max(legend._ncols, 1))
    return 0.1 + rows * legend._fontsize * 1.5 / 72.0 + (0.25 if legend.get_title().get_text() else 0.0)


#: Room (inches) around each stacked panel: left of it for the y tick labels and axis label, right,
#: above for its title, below for the x tick labels and axis label.
MARGINS_IN = {"left": 0.8, "right": 0.15, "top": 0.35, "bottom": 0.55}


def narrow_layout(figure: Figure, width_in: float = PHONE_WIDTH_IN) -> Figure:
    """Lay ``figure`` out for a phone's column, in place (see the module's docstring); returns it.

    The layout is placed by hand (margins :data:`MARGINS_IN`), without a layout engine, so that
    the narrow copy costs one drawing.
    """
    width, height = figure.get_size_inches()
    cells = _cells(figure)
    grid_rows = max((len({ax.get_subplotspec().get_topmost_subplotspec().rowspan.start for ax in figure.axes
                           if ax.get_subplotspec() is not None})), 1)
    panels = max(len(cells), 1)
    low, high = PANEL_HEIGHT_IN
    axes_height = min(max(height / grid_rows, low), high, width_in * 0.9) - 0.5
    under_axes, under_figure = _legends_under(figure)
    with contextlib.suppress(RuntimeError):  # colour bars tied to a layout engine keep it
        figure.set_layout_engine("none")
    title = 0.45 if figure._suptitle is not None else 0.0
    panel = axes_height + MARGINS_IN["top"] + MARGINS_IN["bottom"] + under_axes
    total = panels * panel + title + under_figure
    figure.set_size_inches(width_in, total)
    grid = GridSpec(panels, 1, figure=figure, left=MARGINS_IN["left"] / width_in,
                    right=1 - MARGINS_IN["right"] / width_in,
                    top=1 - (title + MARGINS_IN["top"]) / total,
                    bottom=(MARGINS_IN["bottom"] + under_axes + under_figure) / total,
                    hspace=(panel - axes_height) / axes_height)
    if cells:
        _stack_axes(figure, grid)
    for text in figure.findobj(Text):
        if len(text.get_text()) > 30:
            text.set_wrap(True)
    return figure


def narrow_copy(figure: Figure, width_in: float = PHONE_WIDTH_IN) -> Figure:
    """A copy of ``figure`` laid out for a phone's column (the figure itself is left as it was).

    The copy is made by pickling; it is not left among pyplot's figures, and pyplot's current
    figure stays the same.
    """
    from matplotlib import pyplot as plt
    from matplotlib._pylab_helpers import Gcf

    active = Gcf.get_active()
    copy = pickle.loads(pickle.dumps(figure))
    if plt.fignum_exists(copy.number) and plt.figure(copy.number) is copy:
        plt.close(copy)
    if active is not None and active in Gcf.get_all_fig_managers():
        Gcf.set_active(active)
    FigureCanvasAgg(copy)  # a canvas to draw on, outside pyplot
    return narrow_layout(copy, width_in)


def tight_image(figure: Figure) -> Image.Image:
    """The figure's tight box (what is drawn, with ``savefig``'s 0.1 in pad) as an RGB image.

    One drawing when everything drawn lies inside the figure's frame (the canvas is cropped),
    else one more, saving into the box that holds everything (as ``bbox_inches="tight"``).
    """
    figure.canvas.draw()
    box = figure.get_tightbbox(figure.canvas.get_renderer())  # inches
    width, height = figure.get_size_inches()
    if box.x0 >= 0 and box.y0 >= 0 and box.x1 <= width and box.y1 <= height:
        pad, dpi = 0.1, figure.dpi
        left, bottom = max(box.x0 - pad, 0.0), max(box.y0 - pad, 0.0)
        right, top = min(box.x1 + pad, width), min(box.y1 + pad, height)
        image = Image.fromarray(np.asarray(figure.canvas.buffer_rgba())).convert("RGB")
        return image.crop((int(left * dpi), int((height - top) * dpi),
                           int(np.ceil(right * dpi)), int(np.ceil((height - bottom) * dpi))))
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", bbox_inches=box.padded(0.1))
    return Image.open(io.BytesIO(buffer.getvalue())).convert("RGB")


def picture_html(png: bytes, narrow_png: bytes, alt: str = "") -> str:
    """A ``<picture>``: the narrow PNG for windows up to :data:`NARROW_MEDIA`, the usual one otherwise."""
    def uri(data: bytes) -> str:
        return "data:image/png;base64," + base64.b64encode(data).decode("ascii")
    return (f'<picture class="pfcourse-figure"><source media="{NARROW_MEDIA}" srcset="{uri(narrow_png)}">'
            f'<img src="{uri(png)}" alt="{html.escape(alt)}"></picture>')


def _print_png(figure: Figure) -> bytes:
    """The figure as the notebook shows it: its tight box at the figure's dpi.

    Where the tests' legibility check is installed (it wraps IPython's ``print_figure``), through
    that function, so every figure shown, narrow copies included, is checked; elsewhere with
    :func:`tight_image` (one drawing instead of ``print_figure``'s two).
    """
    from IPython.core import pylabtools

    if getattr(pylabtools.print_figure, "_checks_legibility", False) or figure.dpi != mpl.rcParams["savefig.dpi"]:
        return pylabtools.print_figure(figure, "png", bbox_inches="tight")
    out = io.BytesIO()
    tight_image(figure).save(out, format="PNG")
    return out.getvalue()


def figure_bundle(figure: Figure) -> dict:
    """The display data of a figure: ``image/png``, and ``text/html`` with the narrow copy when needed."""
    png = _print_png(figure)
    bundle = {"image/png": base64.b64encode(png).decode("ascii")}
    dpi = mpl.rcParams["savefig.dpi"]
    dpi = figure.dpi if dpi == "figure" else dpi
    if _ENABLED[-1] and needs_narrow_copy(png_width(png), smallest_font_px(figure, dpi)):
        try:
            narrow = _print_png(narrow_copy(figure))
        except (pickle.PicklingError, TypeError, AttributeError, ValueError) as exc:
            warnings.warn(f"no narrow copy of a figure for phones: {type(exc).__name__}: {exc}", stacklevel=2)
        else:
            bundle["text/html"] = picture_html(png, narrow)
    return bundle


def install() -> bool:
    """Show every matplotlib figure in IPython with :func:`figure_bundle` (no-op outside IPython).

    Registers it as the figure's mimebundle formatter and removes the inline backend's PNG
    formatter of figures, so each figure is drawn once for its usual PNG. Returns whether
    IPython is running.
    """
    try:
        from IPython import get_ipython
    except ImportError:
        return False
    shell = get_ipython()
    if shell is None:
        return False
    formatters = shell.display_formatter

    def bundle(figure: Figure, include=None, exclude=None):
        formatters.formatters["image/png"].pop(Figure, None)  # the inline backend registers it again
        return figure_bundle(figure)

    if _INSTALLED.get("shell") is not shell:
        formatters.mimebundle_formatter.for_type(Figure, bundle)
        _INSTALLED["shell"] = shell
    formatters.formatters["image/png"].pop(Figure, None)
    return True
