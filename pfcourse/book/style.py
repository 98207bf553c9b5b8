"""The book's figure style: colours, matplotlib settings and small drawing helpers.

Part of the core (it imports no scenario), so that every layer's figures share it.

Call :func:`use_style` once at the top of a notebook.  The functions here draw
onto axes they are given (or create), label their axes with units, and return
the artists, so a notebook can still adjust them.
"""

from __future__ import annotations

import matplotlib as mpl
from matplotlib import ticker
from matplotlib.patches import Ellipse

from pfcourse.book import narrow_figures
from pfcourse.diagnostics import confidence_ellipse

#: Colours used for the same thing in every figure.
COLORS = {
    "truth": "black",
    "robot": "tab:blue",
    "estimate": "tab:red",
    "kalman": "tab:green",
    "particles": "tab:orange",
    "seen": "tab:green",
    "unseen": "tab:gray",
    "fov": "tab:cyan",
}

STYLE = {
    "figure.figsize": (7.0, 4.2),
    "figure.dpi": 100,
    "savefig.dpi": 100,
    "axes.grid": True,
    "grid.alpha": 0.3,
    "axes.spines.top": False,
    "axes.spines.right": False,
    "axes.titlesize": 11,
    "axes.labelsize": 10,
    "legend.fontsize": 9,
    "legend.frameon": False,
    "animation.embed_limit": 40.0,
}


def use_style() -> None:
    """Apply the book's matplotlib style (sizes, grid, fonts) to every later figure.

    In a notebook it also shows every wide figure with a narrow copy for phones
    (:mod:`pfcourse.book.narrow_figures`).
    """
    mpl.rcParams.update(STYLE)
    narrow_figures.install()



def plain_log_axis(ax, which: str = "y", subs: tuple[float, ...] = (1.0, 3.0)) -> None:
    """Put ``which`` (``"x"``, ``"y"`` or ``"xy"``) of ``ax`` on a log scale that is cheap to redraw.

    Major ticks at ``subs`` times the powers of ten (``(1, 3)`` gives 0.1, 0.3, 1, 3, ...;
    ``(1, 2, 5)`` gives 0.1, 0.2, 0.5, 1, ...), labelled as plain numbers (``%g``), and no minor
    ticks.  With two or more ``subs``, a view holding fewer than two of these ticks falls back
    to linear-style ticks (matplotlib's ``LogLocator``), so it is never left unlabelled.
    Matplotlib's default log axis
    typesets every label as mathtext (``10^{-1}``) and adds eight minor ticks per decade; on a
    widget panel those two cost about a third of a redraw, and they add no information that the
    gridlines at the labelled ticks do not give.
    """
    for name in which:
        getattr(ax, f"set_{name}scale")("log")
        axis = getattr(ax, f"{name}axis")
        axis.set_major_locator(ticker.LogLocator(subs=subs))
        axis.set_major_formatter(ticker.FormatStrFormatter("%g"))
        axis.set_minor_locator(ticker.NullLocator())


def ellipse_patch(mean, cov, probability: float = 0.95, **kwargs) -> Ellipse:
    """A matplotlib :class:`~matplotlib.patches.Ellipse` for a 2-D Gaussian's confidence region."""
    centre, width, height, angle = confidence_ellipse(mean, cov, probability)
    kwargs.setdefault("fill", False)
    return Ellipse(centre, width, height, angle=angle, **kwargs)
