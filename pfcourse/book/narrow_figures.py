"""A narrow copy of a wide figure, for the HTML book read on a phone.

The HTML book shows a figure at most as wide as its text column: 688 CSS px in a 1280 px
window, :data:`PHONE_COLUMN_PX` (388 px) in a 420 px one. A figure whose tight PNG is ``W``
pixels wide and whose smallest text is ``s`` pixels shows that text at
``s min(1, C / W)`` pixels in a column of ``C`` pixels; on a phone a 1000 px study figure
would show its 9 pt (12.5 px) text at 4.9 px. Below :data:`MIN_TEXT_PX` (8 px), the figure
gets a narrow copy, its axes in one column, made in the cheapest way that reads:

1. **cut** (:func:`sliced_image`): each cell of the figure's grid of axes, with what it draws
   around it (labels, legend, a colour bar in the cell), and the figure's title and legends,
   are cut out of the drawing just made and stacked, row by row: no drawing at all; used
   when the stack is narrow enough for its text to stay at 8 px or more in the column, and
   no x axis shared over rows is labelled on the bottom row only (in a grid of several columns);
2. **laid out anew** (:func:`narrow_layout`, on a pickled copy for a figure shown, in place
   for a panel's figure, which is closed next): the figure :data:`PHONE_WIDTH_IN` inches wide,
   its axes stacked in one column in reading order (an axes sharing its neighbour's y axis
   gets its tick labels back; a shared x axis is labelled under the last panel of each run of
   panels sharing it), a legend right of its axes moved under it, a figure legend
   under the figure (at most two columns), long titles wrapped, margins measured from what
   the axes draw around them (no layout engine where the colour bars allow): one drawing.
   This is the way for a single wide axes and for stacks that would still be too wide.

:func:`install` adds a display formatter to IPython: each figure shown in a notebook is stored
as its usual ``image/png`` (drawn once, :func:`tight_drawing`) and, when it needs the narrow
copy, also as ``text/html``: a ``<picture>`` whose ``<source>`` serves the narrow PNG to
windows up to :data:`NARROW_MEDIA` and whose ``<img>`` is the usual PNG (the HTML book prefers
``text/html``; JupyterLab shows either). The figure shown is not changed. Figures that stay
readable when scaled to the phone's column get no copy (no cost, no weight).
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
from matplotlib.transforms import Bbox, ScaledTranslation
from PIL import Image

#: The HTML book's text column in a 420 px window (a phone), in CSS px (measured in chromium).
PHONE_COLUMN_PX = 388.0
#: The smallest text a reader should have to read in a figure, in CSS px.
MIN_TEXT_PX = 8.0
#: Width of the narrow copy in inches (at the book's 100 dpi, 375 px: the column less a margin).
PHONE_WIDTH_IN = 3.75
#: Height of one stacked axes of the narrow copy, in inches (the original's row height, within these bounds).
PANEL_HEIGHT_IN = (2.2, 3.0)
#: Room (inches) under a stacked panel whose x axis is labelled under the panel below (tick marks only).
UNLABELLED_GAP_IN = 0.15
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


def shown_px(text_px: float, width_px: float, column_px: float) -> float:
    """The size on the page (CSS px) of a text ``text_px`` pixels high in a PNG ``width_px`` wide, shown
    at most as wide as a column of ``column_px``: ``text_px min(1, column_px / width_px)``."""
    return text_px * min(1.0, column_px / width_px) if width_px > 0 else text_px


def needs_narrow_copy(width_px: float, smallest_px: float, column_px: float = PHONE_COLUMN_PX) -> bool:
    """Whether a figure ``width_px`` wide, whose smallest text is ``smallest_px``, is too small to
    read scaled to the phone's column (:func:`shown_px` below :data:`MIN_TEXT_PX`)."""
    return shown_px(smallest_px, width_px, column_px) < MIN_TEXT_PX


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
    _label_shared_x_below(figure)
    for axes in figure.axes:
        if axes.get_subplotspec() is not None:
            axes._set_position(axes.get_subplotspec().get_position(figure))
    return len(_cells(figure))


def _x_labels_shown(cells: list[list]) -> list[bool | None]:
    """For each cell in stacking order, whether its x axis is labelled under it in the stacked column:
    a shared x axis only under the last of a run of panels sharing it (``None``: not shared, as drawn)."""
    stacked = [cell[0] for cell in cells]
    return [None if len(siblings := axes.get_shared_x_axes().get_siblings(axes)) < 2
            else below is None or below not in siblings for axes, below in zip(stacked, [*stacked[1:], None])]


def _label_shared_x_below(figure: Figure) -> None:
    """In the stacked column, an x axis shared with the panel below is labelled there only
    (:func:`_x_labels_shown`), with the axis label of a sibling that has one (``sharex`` kept them on
    the original's bottom row only)."""
    cells = _cells(figure)
    for cell, shown in zip(cells, _x_labels_shown(cells)):
        if shown is None:
            continue
        axes = cell[0]
        siblings = axes.get_shared_x_axes().get_siblings(axes)
        axes.xaxis.set_tick_params(which="both", labelbottom=shown)
        if shown and not axes.get_xlabel():
            axes.set_xlabel(next((s.get_xlabel() for s in siblings if s.get_xlabel()), ""))
        axes.xaxis.label.set_visible(shown)


def _x_labelled_on_bottom_row_only(figure: Figure) -> bool:
    """Whether the figure's grid has several columns and an x axis shared by panels of several rows
    is labelled on the bottom row only (``sharex``): cut out and stacked row by row, those labels
    would sit under the wrong panels."""
    cells = _cells(figure)
    columns = {cell[0].get_subplotspec().get_topmost_subplotspec().colspan.start for cell in cells}
    return len(columns) > 1 and any(len(cell[0].get_shared_x_axes().get_siblings(cell[0])) > 1
                                    and not cell[0].xaxis.get_tick_params()["labelbottom"] for cell in cells)


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
    """Put legends that sit right of their axes under them, and figure legends under the figure, in
    at most two columns (each made anew from its entries, font and title).

    Returns the heights (inches) to leave under an axes and under the figure for them.
    """
    below = ScaledTranslation(0, -0.55, figure.dpi_scale_trans)  # under the tick labels and axis label
    under_axes = under_figure = 0.0
    for axes in figure.axes:
        legend = _outside_legend(axes)
        if legend is not None:
            new = _two_columns(axes, legend, loc="upper center", bbox_to_anchor=(0.5, 0.0),
                               bbox_transform=axes.transAxes + below)
            under_axes = max(under_axes, _legend_height(new))
    for legend in list(figure.legends):
        new = _two_columns(figure, legend, loc="lower center", bbox_to_anchor=(0.5, 0.0),
                           bbox_transform=figure.transFigure)
        under_figure += _legend_height(new)
    return under_axes, under_figure


def _outside_legend(axes):
    """The axes' legend if it is anchored at or past the axes' right edge (outside them), else None."""
    legend = axes.get_legend()
    if legend is None:
        return None
    anchor = legend.get_bbox_to_anchor().transformed(axes.transAxes.inverted())
    return legend if anchor.x0 >= 0.99 else None


def _two_columns(owner, legend, **placement):
    """``legend`` of ``owner`` (an axes or the figure) replaced by one of the same entries in at
    most two columns, placed as ``placement`` says."""
    labels = [text.get_text() for text in legend.get_texts()]
    title = legend.get_title().get_text()
    legend.remove()
    return owner.legend(legend.legend_handles, labels, ncols=min(2, len(labels)), fontsize=legend._fontsize,
                        frameon=legend.get_frame_on(), title=title or None, **placement)


def _legend_height(legend) -> float:
    """Inches a legend takes (its rows of text and a margin)."""
    rows = -(-len(legend.get_texts()) // max(legend._ncols, 1))
    return 0.1 + rows * legend._fontsize * 1.5 / 72.0 + (0.25 if legend.get_title().get_text() else 0.0)


#: Bounds (inches) of the room kept around each stacked panel for what its axes draw outside their
#: box (tick labels and axis labels, the title, a colour bar's labels), measured on the figure.
MARGIN_BOUNDS_IN = {"left": (0.3, 1.8), "right": (0.1, 1.2), "top": (0.1, 0.8), "bottom": (0.1, 0.9)}


def _margins(figure: Figure) -> dict[str, float]:
    """Inches each side of the axes' boxes needs for what they draw outside them (legends apart),
    the most over the figure's axes, with a 0.12 in pad (tick labels change as the axes do), within :data:`MARGIN_BOUNDS_IN`."""
    renderer = figure.canvas.get_renderer()
    room = dict.fromkeys(MARGIN_BOUNDS_IN, 0.0)
    for axes in figure.axes:
        if not axes.get_visible():
            continue
        tight, box = axes.get_tightbbox(renderer, bbox_extra_artists=[]), axes.bbox
        for side, inches in (("left", box.x0 - tight.x0), ("right", tight.x1 - box.x1),
                             ("top", tight.y1 - box.y1), ("bottom", box.y0 - tight.y0)):
            room[side] = max(room[side], inches / figure.dpi)
    return {side: min(max(room[side] + 0.12, low), high) for side, (low, high) in MARGIN_BOUNDS_IN.items()}


def _panel_height(axes, width_in: float, default: float) -> float:
    """Height (inches) of a stacked panel: its axes' own shape for a fixed aspect (a map), else ``default``."""
    aspect = axes.get_aspect()
    if aspect == "auto":
        return default
    low, high = PANEL_HEIGHT_IN
    return min(max(width_in * float(aspect) * axes.get_data_ratio(), 1.2), high)


def _wrapped_height(figure: Figure, text: Text, width_in: float) -> float:
    """Inches a text takes wrapped at ``width_in`` (each of its lines as wide as drawn, cut into
    as many lines as that width needs), with a margin."""
    renderer = figure.canvas.get_renderer()
    lines = 0
    for line in text.get_text().split("\n"):
        drawn, _, _ = renderer.get_text_width_height_descent(line, text.get_fontproperties(), ismath=False)
        lines += max(1, int(np.ceil(drawn / figure.dpi / (0.9 * width_in))))
    return 0.15 + lines * text.get_fontsize() * 1.35 / 72.0


def narrow_layout(figure: Figure, width_in: float = PHONE_WIDTH_IN) -> Figure:
    """Lay ``figure`` out for a phone's column, in place (see the module's docstring); returns it.

    The layout is placed by hand (margins measured by :func:`_margins`), without a layout engine
    where the figure's colour bars allow, so that the narrow copy costs one drawing.
    """
    width, height = figure.get_size_inches()
    cells = _cells(figure)
    margins = _margins(figure)
    grid_rows = max((len({ax.get_subplotspec().get_topmost_subplotspec().rowspan.start for ax in figure.axes
                           if ax.get_subplotspec() is not None})), 1)
    low, high = PANEL_HEIGHT_IN
    default = min(max(height / grid_rows, low), high, width_in * 0.8)
    loose_bars = [ax for ax in figure.axes if ax.get_subplotspec() is None and hasattr(ax, "_colorbar")]
    under_axes, under_figure = _legends_under(figure)
    with contextlib.suppress(RuntimeError):  # colour bars tied to a layout engine keep it
        figure.set_layout_engine("none")
    placed = figure.get_layout_engine() is None
    bar_room = margins["right"] + 0.25 if placed and loose_bars else 0.0  # a shared colour bar, beside panel 1
    right = margins["right"] + bar_room
    inner = width_in - margins["left"] - right
    heights = [_panel_height(cell[0], inner, default) for cell in cells] or [default]
    titles = [t for ax in figure.axes for t in (ax.title,) if len(t.get_text()) > 30]
    if figure._suptitle is not None:
        titles.append(figure._suptitle)
    for text in titles:
        text.set_wrap(True)  # a long title wraps at the figure's edge instead of widening it
    top = margins["top"] + (0.2 if titles else 0.0)
    title = _wrapped_height(figure, figure._suptitle, width_in) if figure._suptitle is not None else 0.0
    shown = _x_labels_shown(cells)
    # between panels, room for their x labels, unless only the last panel shows them (one shared x axis)
    between = margins["bottom"] if not cells or any(s is None or s for s in shown[:-1]) else UNLABELLED_GAP_IN
    gap = top + between + under_axes
    total = sum(heights) + len(heights) * gap + title + under_figure
    figure.set_size_inches(width_in, total)
    grid = GridSpec(len(heights), 1, figure=figure, height_ratios=heights, left=margins["left"] / width_in,
                    right=1 - right / width_in, top=1 - (title + top) / total,
                    bottom=(margins["bottom"] + under_axes + under_figure) / total,
                    hspace=gap / (sum(heights) / len(heights)))
    if cells:
        _stack_axes(figure, grid)
        if bar_room:
            first = grid[0, 0].get_position(figure)
            for bar in loose_bars:
                bar.set_position([first.x1 + 0.1 / width_in, first.y0, 0.15 / width_in, first.height])
    return figure


def sliced_image(figure: Figure, drawing: tuple[Image.Image, tuple[int, int]],
                 column_px: float = PHONE_COLUMN_PX) -> Image.Image | None:
    """The figure's panels cut out of its drawing and stacked in one column, row by row: no drawing.

    ``drawing`` is the figure's last drawing and its corner on the canvas (:func:`tight_drawing`).
    The pieces are the figure's title, each cell of its grid of axes (with what the axes draw
    around them: labels, legend, a colour bar in the cell), a legend placed right of its axes
    (under them), and the figure's legends. ``None`` when the figure has fewer than two cells and
    no such legend, when its shared x axes are labelled on its bottom row only (in several columns),
    when a piece lies outside the drawing, or when the
    stack would still need scaling that brings its text under :data:`MIN_TEXT_PX` in a column of
    ``column_px``: then :func:`narrow_layout` draws it anew.
    """
    cells = _cells(figure)
    outside = {axes: _outside_legend(axes) for cell in cells for axes in cell if _outside_legend(axes)}
    if (len(cells) < 2 and not outside and len(figure.subfigs) < 2) or _x_labelled_on_bottom_row_only(figure):
        return None
    image, (left, top) = drawing
    renderer = figure.canvas.get_renderer()
    height = figure.bbox.height
    boxes = [figure._suptitle.get_window_extent(renderer)] if figure._suptitle is not None else []
    boxes += [subfigure.get_tightbbox(renderer) for subfigure in figure.subfigs]  # side by side: one piece each
    for cell in cells:  # a cell without its legend placed outside it, then that legend
        boxes.append(Bbox.union([axes.get_tightbbox(renderer, bbox_extra_artists=[
            artist for artist in axes.get_default_bbox_extra_artists() if artist is not outside.get(axes)])
            for axes in cell]))
        boxes += [outside[axes].get_window_extent(renderer) for axes in cell if axes in outside]
    boxes += [legend.get_window_extent(renderer) for legend in figure.legends]
    pad = 0.05 * figure.dpi
    pieces = []
    for box in boxes:  # canvas pixels (y up) to the drawing's (y down, from its corner)
        x0, x1 = box.x0 - left, box.x1 - left
        y0, y1 = height - box.y1 - top, height - box.y0 - top
        if x0 < -1 or y0 < -1 or x1 > image.width + 1 or y1 > image.height + 1:
            return None  # drawn outside the drawing
        pieces.append(image.crop((max(int(x0 - pad), 0), max(int(y0 - pad), 0),
                                  min(int(np.ceil(x1 + pad)), image.width), min(int(np.ceil(y1 + pad)), image.height))))
    width = max(piece.width for piece in pieces)
    if needs_narrow_copy(width, smallest_font_px(figure, figure.dpi), column_px):
        return None
    stack = Image.new("RGB", (width, sum(piece.height for piece in pieces)), "white")
    row = 0
    for piece in pieces:
        stack.paste(piece, ((width - piece.width) // 2, row))
        row += piece.height
    return stack


def narrow_image(figure: Figure, drawing: tuple[Image.Image, tuple[int, int]]) -> Image.Image:
    """The figure's narrow copy: its panels cut from ``drawing`` and stacked (:func:`sliced_image`)
    where that reads, else the figure laid out anew in place (:func:`narrow_layout`) and drawn."""
    return sliced_image(figure, drawing) or tight_image(narrow_layout(figure))


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


def tight_drawing(figure: Figure) -> tuple[Image.Image, tuple[int, int]]:
    """The figure's tight box (what is drawn, with ``savefig``'s 0.1 in pad) as an RGB image, and
    where that image's top left corner lies on the figure's canvas (pixels from its left and top).

    One drawing when everything drawn lies inside the figure's frame (the canvas is cropped),
    else one more, saving into the box that holds everything (as ``bbox_inches="tight"``).
    """
    figure.canvas.draw()
    box = figure.get_tightbbox(figure.canvas.get_renderer())  # inches
    width, height = figure.get_size_inches()
    dpi = figure.dpi
    if box.x0 >= 0 and box.y0 >= 0 and box.x1 <= width and box.y1 <= height:
        pad = 0.1
        left, bottom = max(box.x0 - pad, 0.0), max(box.y0 - pad, 0.0)
        right, top = min(box.x1 + pad, width), min(box.y1 + pad, height)
        corner = (int(left * dpi), int((height - top) * dpi))
        image = Image.fromarray(np.asarray(figure.canvas.buffer_rgba())).convert("RGB")
        return image.crop((*corner, int(np.ceil(right * dpi)), int(np.ceil((height - bottom) * dpi)))), corner
    buffer = io.BytesIO()
    padded = box.padded(0.1)
    figure.savefig(buffer, format="png", bbox_inches=padded)
    corner = (int(round(padded.x0 * dpi)), int(round((height - padded.y1) * dpi)))
    return Image.open(io.BytesIO(buffer.getvalue())).convert("RGB"), corner


def tight_image(figure: Figure) -> Image.Image:
    """The figure's tight box as an RGB image (:func:`tight_drawing`)."""
    return tight_drawing(figure)[0]


def picture_html(png: bytes, narrow_png: bytes, alt: str = "") -> str:
    """A ``<picture>``: the narrow PNG for windows up to :data:`NARROW_MEDIA`, the usual one otherwise."""
    def uri(data: bytes) -> str:
        return "data:image/png;base64," + base64.b64encode(data).decode("ascii")
    return (f'<picture class="pfcourse-figure"><source media="{NARROW_MEDIA}" srcset="{uri(narrow_png)}">'
            f'<img src="{uri(png)}" alt="{html.escape(alt)}"></picture>')


def _encode(image: Image.Image) -> bytes:
    out = io.BytesIO()
    image.save(out, format="PNG")
    return out.getvalue()


def _print_png(figure: Figure) -> tuple[bytes, tuple[Image.Image, tuple[int, int]] | None]:
    """The figure as the notebook shows it (its tight box at the figure's dpi), and that drawing
    (:func:`tight_drawing`: one drawing instead of ``print_figure``'s two) when it was made here.

    Where the tests' legibility check is installed (it wraps IPython's ``print_figure`` and names
    its check there), the figure is checked first, so every figure shown, narrow copies laid out
    anew included, is checked.
    """
    from IPython.core import pylabtools

    if figure.dpi != mpl.rcParams["savefig.dpi"]:
        return pylabtools.print_figure(figure, "png", bbox_inches="tight"), None
    check = getattr(pylabtools.print_figure, "_checks_legibility", None)
    if callable(check):
        check(figure)
    drawing = tight_drawing(figure)
    return _encode(drawing[0]), drawing


def figure_bundle(figure: Figure) -> dict:
    """The display data of a figure: ``image/png``, and ``text/html`` with the narrow copy when needed."""
    png, drawing = _print_png(figure)
    bundle = {"image/png": base64.b64encode(png).decode("ascii")}
    if not _ENABLED[-1]:
        return bundle
    if drawing is None:  # a figure at another dpi: the book's own drawing decides (``print_figure`` pads
        drawing = tight_drawing(figure)  # beyond the frame, which this crop does not)
    if needs_narrow_copy(drawing[0].width, smallest_font_px(figure, figure.dpi)):
        narrow = None
        try:
            sliced = sliced_image(figure, drawing)
            narrow = _encode(sliced) if sliced is not None else _print_png(narrow_copy(figure))[0]
        except (pickle.PicklingError, TypeError, AttributeError, ValueError) as exc:
            warnings.warn(f"no narrow copy of a figure for phones: {type(exc).__name__}: {exc}", stacklevel=2)
        if narrow is not None:
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
