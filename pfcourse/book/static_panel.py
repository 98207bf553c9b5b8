"""A control panel's figures over a grid of control values, as one HTML block that needs no kernel.

A panel is a pure function of its control values: ``draw(**values)`` makes one figure.
So the HTML book can offer a working panel without Python: when the chapter executes,
:func:`render_grid` calls ``draw`` at every point of a small grid

.. math::

    G = V_1 \\times V_2 \\times \\dots \\times V_k ,

(the listed values of the *main* controls, every other control at its default), then, one
factor at a time, at each other value of each *side* control with every other control at its
default; it stores each figure as a PNG, and :func:`panel_html` writes the controls, the figure
of the current values and the other figures as data. ``web/static/pfcourse-panels.js``
(served by the book) switches the image when a control moves: point ``(i_1, ..., i_k)`` of the
main grid is image number ``sum_j i_j * prod_{l > j} |V_l|`` (row-major order, as
:func:`itertools.product` enumerates it); value ``i`` of side control ``s`` is image
``side[s][i]``. A combination that was not computed (a side control moved while another control
is off its default) shows the figure of the control moved last, with the others at their
defaults, and says so in place. A control with a single value is shown disabled, with its value.
"""

from __future__ import annotations

import base64
import contextlib
import html
import io
import itertools
import json
import os
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from fractions import Fraction

import matplotlib.pyplot as plt
import numpy as np
from PIL import Image

from pfcourse.book import narrow_figures
from pfcourse.errors import ParameterError
from pfcourse.studies.executor import run_tasks
from pfcourse.book.legibility import LegibilityWarning, installed_check

#: Seconds a pool of workers may go without finishing a figure before the rest of the grid is
#: rendered in this process instead (one figure of the book takes well under a second; two chapter
#: executions under heavy load took about 10 minutes; the cause is not known, a stalled pool per
#: panel at the former 120 s would explain it).
POOL_TIMEOUT = 30.0

#: The one line every static panel shows under its controls.
LIVE_NOTE = ("On this page the panel switches between figures computed when the chapter ran, for the "
             "values each control offers; every value in between is live in JupyterLab "
             "(<code>python3 tasks.py lab</code>).")


@dataclass(frozen=True)
class StaticControl:
    """One control as the HTML page shows it.

    ``values`` are the values offered (one value, with ``enabled`` False, for a control
    that offers no other); ``index`` is the position of the control's current (default) value;
    ``kind`` is ``"range"`` (an ordered slider) or ``"select"`` (a drop-down or a box);
    ``main`` is True for a control of the full grid, False for a side control, whose other
    values are drawn one factor at a time.
    """

    name: str
    description: str
    values: tuple
    index: int
    kind: str
    enabled: bool
    main: bool = True


@dataclass(frozen=True)
class StaticPanel:
    """The controls, the grid's figures (PNG bytes, row-major order), printed text of each point and narrow copies."""

    controls: tuple[StaticControl, ...]
    images: tuple[bytes, ...]
    texts: tuple[str, ...]
    #: For each image, its narrow copy for a phone's column (:mod:`pfcourse.book.narrow_figures`), or None
    #: where the image stays readable scaled to it; empty: none made.
    narrow_images: tuple[bytes | None, ...] = ()

    @property
    def strides(self) -> list[int]:
        """Image number of main-grid point ``(i_1, ..., i_k)`` is ``sum_j i_j * strides[j]`` (row-major;
        a side control's stride is 0: the main grid has it at its default)."""
        strides, stride = [], 1
        for control in reversed(self.controls):
            strides.append(stride if control.main else 0)
            stride *= len(control.values) if control.main else 1
        return strides[::-1]

    @property
    def grid_size(self) -> int:
        """Number of figures of the main grid (the side figures follow them)."""
        return int(np.prod([len(c.values) for c in self.controls if c.main]))

    @property
    def side(self) -> dict[int, dict[int, int]]:
        """``side[k][i]``: image number of value ``i`` of side control ``k``, the others at their defaults
        (the default value itself is the main grid's image at the defaults)."""
        out, number = {}, self.grid_size
        for k, control in enumerate(self.controls):
            if control.main:
                continue
            out[k] = {}
            for i in range(len(control.values)):
                if i == control.index:
                    out[k][i] = self.current
                else:
                    out[k][i], number = number, number + 1
        return out

    @property
    def current(self) -> int:
        """Image number of the controls' current values."""
        return sum(c.index * s for c, s in zip(self.controls, self.strides))

    def image_of(self, values: Mapping[str, object]) -> int | None:
        """Image number of the figure drawn at the controls' ``values``, or None if the panel has none.

        Every main-grid point has one; a side control's other values have one with every other control
        at its default.  A value matches only if it equals one the control offers (a slider's float
        that is not on the grid falls through to a live drawing)."""
        index = []
        for control in self.controls:
            found = [i for i, v in enumerate(control.values) if _same_value(v, values.get(control.name))]
            if not found:
                return None
            index.append(found[0])
        off_default = [k for k, (c, i) in enumerate(zip(self.controls, index)) if not c.main and i != c.index]
        if not off_default:
            return sum(i * s for i, s in zip(index, self.strides))
        k = off_default[0]
        others_at_default = all(i == c.index for j, (c, i) in enumerate(zip(self.controls, index)) if j != k)
        return self.side[k][index[k]] if len(off_default) == 1 and others_at_default else None

    @property
    def size(self) -> int:
        """Bytes of PNG data the panel carries (before base64), narrow copies included."""
        return sum(len(image) for image in (*self.images, *self.narrow_images) if image)


def format_value(value) -> str:
    """A control value as its readout shows it (``0.1``, ``1/3``, ``1000``, ``(0, 6)``, ``robot``).

    A float that is a fraction with a small denominator no short decimal writes (thirds,
    sixths, sevenths, ninths, ...) is written as that fraction.
    """
    if isinstance(value, (float, np.floating)) and not isinstance(value, bool):
        value = float(value)
        if np.isfinite(value) and value != round(value):
            fraction = Fraction(value).limit_denominator(12)
            if abs(float(fraction) - value) < 1e-9 and len(f"{value:g}") > 5:
                return f"{fraction.numerator}/{fraction.denominator}"
        return f"{value:g}"
    if isinstance(value, tuple):
        return "–".join(format_value(v) for v in value)
    return str(value)


def _png(figure, colours: int = 256) -> bytes:
    """The figure as a palette PNG (at most ``colours`` colours: half the size of RGB, same look).

    Cropped to what is drawn, like the notebook's inline figures (``bbox_inches="tight"``,
    with its 0.1 in pad): from the one drawing on the canvas when everything drawn lies
    inside the figure's frame, else (a label or legend outside it) by saving once more
    into the box that holds everything.
    """
    return _quantized_png(narrow_figures.tight_image(figure), colours)


def _quantized_png(image: Image.Image, colours: int = 256) -> bytes:
    """An RGB image as a palette PNG of at most ``colours`` colours."""
    quantized = image.quantize(colors=colours, method=Image.Quantize.FASTOCTREE, dither=Image.Dither.NONE)
    out = io.BytesIO()
    quantized.save(out, format="PNG")
    return out.getvalue()


#: The draw function, the grid points of the rendering under way and the legibility check (the
#: tests', or None); forked workers inherit them (nothing is pickled but the point's number and
#: what comes back).
_job: tuple[Callable[..., object], list[dict], Callable | None] | None = None


def _render_point(number: int) -> tuple[bytes, str, bytes | None, list[str]]:
    """PNG, printed text, narrow copy's PNG (or None) of grid point ``number`` of the rendering under
    way (see :data:`_job`), and what the legibility check found in its figure (under the tests)."""
    draw, points, check = _job
    values = points[number]
    before = set(plt.get_fignums())
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        draw(**values)
    new = [n for n in plt.get_fignums() if n not in before]
    if len(new) != 1:
        for figure_number in new:
            plt.close(figure_number)
        raise ParameterError(f"a panel's draw must make one figure; at {values} it made {len(new)}")
    figure = plt.figure(new[0])
    problems: list[str] = []
    if check is not None:  # in a worker, whose warnings would not reach the notebook: sent back
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", LegibilityWarning)
            check(figure)
        problems = [str(w.message) for w in caught if issubclass(w.category, LegibilityWarning)]
    drawing = narrow_figures.tight_drawing(figure)
    image, narrow = _quantized_png(drawing[0]), None
    if narrow_figures.needs_narrow_copy(drawing[0].width, narrow_figures.smallest_font_px(figure, figure.dpi)):
        narrow = _quantized_png(narrow_figures.narrow_image(figure, drawing))  # closed next: may change it
    plt.close(figure)
    return image, printed.getvalue(), narrow, problems



def _same_value(a: object, b: object) -> bool:
    """Whether a control's value ``b`` is the grid's value ``a`` (numbers compared as numbers, a bool only as itself)."""
    if isinstance(a, bool) or isinstance(b, bool):
        return a is b
    try:
        return bool(a == b)
    except (TypeError, ValueError):
        return False


def render_grid(draw: Callable[..., object], controls: Sequence[StaticControl],
                workers: int | None = None) -> StaticPanel:
    """Call ``draw`` at every point of the controls' grid; keep each figure (PNG) and what it printed.

    ``draw`` must make exactly one new figure per call (it is closed after it is stored).
    The points are shared out over ``workers`` forked processes (default: one per core;
    1: in this process, as ``draw`` must be when it starts process pools itself); the
    result is the same either way. Raises :class:`~pfcourse.errors.ParameterError`
    naming the grid point where ``draw`` made no figure or several. Where the tests' legibility
    check is installed, every figure is checked, and what it finds is warned here with the point.
    """
    global _job
    names = [c.name for c in controls]
    defaults = {c.name: c.values[c.index] for c in controls}
    main = [c.values if c.main else (c.values[c.index],) for c in controls]
    points = [dict(zip(names, point)) for point in itertools.product(*main)]
    points += [{**defaults, c.name: value} for c in controls if not c.main
               for i, value in enumerate(c.values) if i != c.index]  # one factor at a time
    workers = min(workers or os.cpu_count() or 1, len(points))
    _job = (draw, points, installed_check())
    try:
        if workers < 2:
            rendered = [_render_point(k) for k in range(len(points))]
        else:  # forked workers inherit _job; a pool that stalls is replaced by this process
            rendered = run_tasks(_render_point, [(k,) for k in range(len(points))], workers=workers,
                                 stall_timeout=POOL_TIMEOUT)
    finally:
        _job = None
    for point, (*_, problems) in zip(points, rendered):
        for problem in problems:
            warnings.warn(f"a panel's figure at {point}: {problem}", LegibilityWarning, stacklevel=2)
    return StaticPanel(tuple(controls), tuple(r[0] for r in rendered), tuple(r[1] for r in rendered),
                       tuple(r[2] for r in rendered))


def describe_grid(panel: StaticPanel) -> str:
    """What the panel computed, in a sentence: the main grid, then the side controls one at a time."""
    main = [c.description for c in panel.controls if c.enabled and c.main]
    side = [c.description for c in panel.controls if c.enabled and not c.main]
    def names(items: list[str]) -> str:
        return items[0] if len(items) == 1 else ", ".join(items[:-1]) + " and " + items[-1]
    parts = []
    if len(main) > 1:
        parts.append(f"every combination of {names(main)}")
    elif main:
        parts.append(f"each value of {main[0]}")
    if side:
        parts.append(f"each value of {names(side)} with the other controls at the values the page opens with")
    return f"{len(panel.images)} figures: " + ", and ".join(parts) + "." if parts else "one figure."


def _control_html(control: StaticControl) -> str:
    label = html.escape(control.description)
    name = html.escape(control.name)
    if not control.enabled:
        value = html.escape(format_value(control.values[0]))
        return (f'<label class="pfcourse-control pfcourse-control-off" title="live in JupyterLab">'
                f'<span>{label}</span><input type="text" value="{value}" disabled>'
                f'<span class="pfcourse-readout">live in JupyterLab</span></label>')
    if control.kind == "range":
        ticks = " · ".join(html.escape(format_value(v)) for v in control.values)
        return (f'<label class="pfcourse-control"><span>{label}</span>'
                f'<input type="range" name="{name}" min="0" max="{len(control.values) - 1}" step="1" '
                f'value="{control.index}"><output class="pfcourse-readout">'
                f'{html.escape(format_value(control.values[control.index]))}</output>'
                f'<small class="pfcourse-ticks">{ticks}</small></label>')
    options = "".join(
        f'<option value="{i}"{" selected" if i == control.index else ""}>{html.escape(format_value(v))}</option>'
        for i, v in enumerate(control.values))
    return f'<label class="pfcourse-control"><span>{label}</span><select name="{name}">{options}</select></label>'


def panel_html(panel: StaticPanel, alt: str = "the panel's figure") -> str:
    """The panel as an HTML block: controls, the current figure, the grid's figures as JSON data.

    The figure shown first is the one at the controls' current values, so the page is
    right even before (or without) its script runs.
    """
    strides, current = panel.strides, panel.current
    def uri(image: bytes | None) -> str | None:
        return None if image is None else "data:image/png;base64," + base64.b64encode(image).decode("ascii")
    uris = [uri(image) for image in panel.images]
    data = {
        "controls": [c.name for c in panel.controls],
        "strides": strides,
        "enabled": [c.enabled for c in panel.controls],
        "main": [c.main for c in panel.controls],
        "defaults": [c.index for c in panel.controls],
        "side": {str(k): [values[i] for i in range(len(values))] for k, values in panel.side.items()},
        "descriptions": [c.description for c in panel.controls],
        "labels": [[format_value(v) for v in c.values] for c in panel.controls],
        "texts": list(panel.texts),
        "images": uris,
    }
    if any(panel.narrow_images):  # phones: pfcourse-panels.js shows these in a narrow window
        data["narrow"] = [uri(image) for image in panel.narrow_images]
        data["narrowMedia"] = narrow_figures.NARROW_MEDIA
    controls = "".join(_control_html(c) for c in panel.controls)
    text = panel.texts[current]
    printed = f'<pre class="pfcourse-panel-text">{html.escape(text)}</pre>' if any(panel.texts) else ""
    note = f'<p class="pfcourse-panel-note">{html.escape(describe_grid(panel))} {LIVE_NOTE}</p>'
    nearest = '<p class="pfcourse-panel-nearest" hidden></p>'
    payload = json.dumps(data, separators=(",", ":")).replace("</", "<\\/")
    return (f'<div class="pfcourse-panel" data-current="{current}">'
            f'<div class="pfcourse-panel-controls">{controls}</div>{note}{nearest}{printed}'
            f'<img class="pfcourse-panel-figure" alt="{html.escape(alt)}" src="{uris[current]}">'
            f'<script type="application/json" class="pfcourse-panel-data">{payload}</script></div>')


def static_controls(values: Mapping[str, object], descriptions: Mapping[str, str],
                    kinds: Mapping[str, str], grid: Mapping[str, Sequence],
                    side: Mapping[str, Sequence] | None = None) -> tuple[StaticControl, ...]:
    """The controls of a static panel: the main ``grid``'s with their values, the ``side`` ones with
    theirs (drawn one factor at a time), the others fixed at ``values`` (disabled).

    Raises :class:`~pfcourse.errors.ParameterError` when the grid or the side values name an
    unknown control or the same control twice, list no value, or do not contain a control's
    current value (the page must open on a figure it has).
    """
    side = dict(side or {})
    for what, offered in (("grid", grid), ("side values", side)):
        unknown = set(offered) - set(values)
        if unknown:
            raise ParameterError(f"panel {what} names controls the panel does not have: {sorted(unknown)}")
    both = set(grid) & set(side)
    if both:
        raise ParameterError(f"panel controls both in the grid and in the side values: {sorted(both)}")
    controls = []
    for name, value in values.items():
        offered = grid.get(name, side.get(name))
        if offered is None or (name in side and len(tuple(offered)) == 1):
            controls.append(StaticControl(name, descriptions[name], (value,), 0, kinds[name], False, name in grid))
            continue
        options = tuple(offered)
        kind = "panel grid" if name in grid else "panel side values"
        if not options:
            raise ParameterError(f"{kind} of {name!r} lists no value")
        if value not in options:
            raise ParameterError(f"{kind} of {name!r} does not contain its current value {value!r}: {options}")
        controls.append(StaticControl(name, descriptions[name], options, options.index(value), kinds[name], True,
                                      name in grid))
    return tuple(controls)
