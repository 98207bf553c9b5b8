"""Checks that a drawn figure can be read: no text drawn over another, none too small at column width.

The browser test measures each figure's smallest text on the page; what it cannot see in
a PNG is two labels drawn on top of each other ("PF N=300" over "EKF" in an earlier
accuracy-against-cost plot). :func:`overlapping_texts` finds them from the figure itself:
every visible, non-empty text artist's box on the canvas (title, axis labels, tick labels,
annotations, legend entries, colour-bar labels), and the pairs of boxes that intersect by
more than ``tolerance`` pixels in both directions. :func:`smallest_text_px` measures every one of
those texts (legends and annotations with a font size set in code included) as the HTML book shows
it: a figure wider than the text column (:data:`COLUMN_PX`, at a 1280 px window) is scaled down to
it, and its smallest text must stay at :data:`MIN_TEXT_PX` or more.
"""

from __future__ import annotations

import itertools

from matplotlib.figure import Figure
from matplotlib.text import Text

from pfcourse.book.narrow_figures import shown_px


def overlapping_texts(figure: Figure, tolerance: float = 1.0, drawn: bool = False) -> list[tuple[str, str]]:
    """Pairs ``(text, text)`` of drawn texts of ``figure`` whose boxes overlap (empty list: none).

    Draws the figure once. The texts are those a reader sees: each axes' titles, axis
    labels, offset texts, the visible tick labels inside the view (major and minor, bottom and
    top, left and right: two tick labels of one axis drawn over each other count), its annotations and texts, its
    legend's entries and title; the figure's own texts and legends. ``tolerance`` (pixels)
    ignores boxes that only touch. ``drawn``: the figure was just drawn (it is not drawn again).
    """
    if not drawn:
        figure.canvas.draw()
    renderer = figure.canvas.get_renderer()
    boxes = []
    for text in dict.fromkeys(_drawn_texts(figure)):  # each once (a suptitle is also a figure text)
        if text.get_visible() and text.get_text().strip():
            boxes.append((text.get_text(), text.get_window_extent(renderer)))
    pairs = []
    for (name_a, a), (name_b, b) in itertools.combinations(boxes, 2):
        width = min(a.x1, b.x1) - max(a.x0, b.x0)
        height = min(a.y1, b.y1) - max(a.y0, b.y0)
        if width > tolerance and height > tolerance:
            pairs.append((name_a, name_b))
    return pairs


#: Width (CSS px) of the HTML book's text column in a 1280 px window: a wider figure is scaled down to it.
COLUMN_PX = 688.0
#: The smallest text a reader should have to read in a figure, in CSS px at column width.
MIN_TEXT_PX = 8.0


def smallest_text_px(figure: Figure, dpi: float | None = None, column_px: float = COLUMN_PX,
                     drawn: bool = False) -> tuple[float, str]:
    """The smallest drawn text of ``figure`` as the page shows it (CSS px), and that text.

    A text of ``s`` points is ``s dpi / 72`` pixels in the PNG; the PNG (the figure's tight box,
    ``w`` pixels wide) is shown at ``min(w, column_px)`` pixels, so the text at
    ``s dpi / 72 * min(1, column_px / w)``. ``dpi`` defaults to the figure's. Draws the figure once
    (unless ``drawn``: it was just drawn).
    """
    if not drawn:
        figure.canvas.draw()
    renderer = figure.canvas.get_renderer()
    dpi = float(dpi or figure.dpi)
    width = figure.get_tightbbox(renderer).width * dpi  # inches to PNG pixels
    sizes = [(shown_px(text.get_fontsize() * dpi / 72.0, width, column_px), text.get_text())
             for text in dict.fromkeys(_drawn_texts(figure)) if text.get_visible() and text.get_text().strip()]
    return min(sizes) if sizes else (float("inf"), "")


def _legend_texts(legend) -> list[Text]:
    return [] if legend is None else [*legend.get_texts(), legend.get_title()]


def _drawn_texts(figure: Figure) -> list[Text]:
    texts: list[Text] = list(figure.texts)
    if figure._suptitle is not None:
        texts.append(figure._suptitle)
    for legend in figure.legends:
        texts += _legend_texts(legend)
    for axes in figure.axes:
        if not axes.get_visible():
            continue
        texts += [axes.title, axes._left_title, axes._right_title, axes.xaxis.label, axes.yaxis.label,
                  axes.xaxis.get_offset_text(), axes.yaxis.get_offset_text()]
        box = axes.bbox
        # The visible tick labels of ticks inside the view, major and minor (a log axis labels its
        # minor ticks when it spans few decades), on both sides (label2: top or right).
        texts += [t for t in axes.get_xticklabels(which="both")
                  if box.x0 - 1 <= _centre(t)[0] <= box.x1 + 1]
        texts += [t for t in axes.get_yticklabels(which="both") if box.y0 - 1 <= _centre(t)[1] <= box.y1 + 1]
        texts += [t for t in axes.texts if axes.bbox.overlaps(t.get_window_extent())]
        texts += _legend_texts(axes.get_legend())
    return texts


def _centre(text: Text) -> tuple[float, float]:
    box = text.get_window_extent()
    return (box.x0 + box.x1) / 2, (box.y0 + box.y1) / 2


class LegibilityWarning(UserWarning):
    """A figure shown in a notebook has texts drawn over each other, or text too small at column width."""


def warn_if_illegible(figure: Figure, dpi: float | None = None) -> None:
    """Warn (:class:`LegibilityWarning`) if texts of ``figure`` overlap or its smallest text shows below
    :data:`MIN_TEXT_PX` at the column width (at ``dpi``, default the figure's). Draws the figure once."""
    import warnings

    figure.canvas.draw()
    clashes = overlapping_texts(figure, drawn=True)
    if clashes:
        warnings.warn(f"texts drawn over each other in a figure: {clashes[:4]}", LegibilityWarning, stacklevel=3)
    size, text = smallest_text_px(figure, dpi, drawn=True)
    if size < MIN_TEXT_PX:
        warnings.warn(f"text {text!r} shows at {size:.1f} px at the column width ({COLUMN_PX:.0f} px), "
                      f"below {MIN_TEXT_PX:.0f} px: use the style's font sizes or a narrower figure",
                      LegibilityWarning, stacklevel=3)


def installed_check():
    """The check :func:`check_shown_figures` installed in this process (:func:`warn_if_illegible`), or None."""
    try:
        import IPython.core.pylabtools as pylabtools
    except ImportError:
        return None
    check = getattr(pylabtools.print_figure, "_checks_legibility", None)
    return check if callable(check) else None


def check_shown_figures() -> bool:
    """In IPython, warn (:class:`LegibilityWarning`) for every figure shown with overlapping texts.

    Wraps the function IPython renders figures with (``IPython.core.pylabtools.print_figure``),
    so it must run before matplotlib's inline backend is set up (an IPython startup file: the
    root ``conftest.py`` installs one for the notebook kernels of the tests, where the warning
    becomes an output that strict nbval does not expect). Costs one extra drawing per figure,
    which is why the book's own execution does not use it. Returns whether it was installed.
    """
    import warnings

    try:
        import IPython.core.pylabtools as pylabtools
    except ImportError:
        return False
    original = pylabtools.print_figure
    if getattr(original, "_checks_legibility", False):
        return True

    def print_figure(figure, *args, **kwargs):
        import matplotlib as mpl

        dpi = kwargs.get("dpi") or mpl.rcParams["savefig.dpi"]
        warn_if_illegible(figure, None if dpi == "figure" else dpi)
        return original(figure, *args, **kwargs)

    print_figure._checks_legibility = warn_if_illegible  # for figures shown without print_figure (narrow_figures)
    pylabtools.print_figure = print_figure
    return True
