"""A control panel's figures over a grid of control values, as one HTML block that needs no kernel.

A panel is a pure function of its control values: ``draw(**values)`` makes one figure.
So the HTML book can offer a working panel without Python: when the chapter executes,
:func:`render_grid` calls ``draw`` at every point of a small grid

.. math::

    G = V_1 \\times V_2 \\times \\dots \\times V_k ,

(the listed values of the gridded controls; every other control stays at its value),
stores each figure as a PNG, and :func:`panel_html` writes the controls, the figure of
the current values and the other figures as data. ``web/static/pfcourse-panels.js``
(served by the book) switches the image when a control moves: point ``(i_1, ..., i_k)``
of the grid is image number ``sum_j i_j * prod_{l > j} |V_l|`` (row-major order,
as :func:`itertools.product` enumerates it). Controls that are not gridded are shown
disabled, with their value.
"""

from __future__ import annotations

import base64
import contextlib
import html
import io
import itertools
import json
import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import matplotlib.pyplot as plt
import numpy as np
from PIL import Image

from pfcourse.errors import ParameterError
from pfcourse.executor import run_tasks

#: Seconds a pool of workers may go without finishing a figure before the rest of the grid is
#: rendered in this process instead (one figure of the book takes well under a second).
POOL_TIMEOUT = 120.0

#: The one line every static panel shows under its controls.
LIVE_NOTE = ("On this page the panel switches between figures computed when the chapter ran, for the "
             "values listed under each control; every other value, and the greyed controls, are live "
             "in JupyterLab (<code>python3 tasks.py lab</code>).")


@dataclass(frozen=True)
class StaticControl:
    """One control as the HTML page shows it.

    ``values`` are the grid's values (one value, with ``enabled`` False, for a control
    that is not gridded); ``index`` is the position of the control's current value;
    ``kind`` is ``"range"`` (an ordered slider) or ``"select"`` (a drop-down or a box).
    """

    name: str
    description: str
    values: tuple
    index: int
    kind: str
    enabled: bool


@dataclass(frozen=True)
class StaticPanel:
    """The controls, the grid's figures (PNG bytes, row-major order) and printed text of each point."""

    controls: tuple[StaticControl, ...]
    images: tuple[bytes, ...]
    texts: tuple[str, ...]

    @property
    def strides(self) -> list[int]:
        """Image number of grid point ``(i_1, ..., i_k)`` is ``sum_j i_j * strides[j]`` (row-major)."""
        strides, stride = [], 1
        for control in reversed(self.controls):
            strides.append(stride)
            stride *= len(control.values)
        return strides[::-1]

    @property
    def current(self) -> int:
        """Image number of the controls' current values."""
        return sum(c.index * s for c, s in zip(self.controls, self.strides))

    @property
    def size(self) -> int:
        """Bytes of PNG data the panel carries (before base64)."""
        return sum(len(image) for image in self.images)


def format_value(value) -> str:
    """A control value as its readout shows it (``0.1``, ``1000``, ``(0, 6)``, ``robot``)."""
    if isinstance(value, float):
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
    figure.canvas.draw()
    renderer = figure.canvas.get_renderer()
    box = figure.get_tightbbox(renderer)  # inches
    width, height = figure.get_size_inches()
    if box.x0 >= 0 and box.y0 >= 0 and box.x1 <= width and box.y1 <= height:
        pad, dpi = 0.1, figure.dpi  # savefig's pad_inches, inside the figure's frame
        left, bottom = max(box.x0 - pad, 0.0), max(box.y0 - pad, 0.0)
        right, top = min(box.x1 + pad, width), min(box.y1 + pad, height)
        image = Image.fromarray(np.asarray(figure.canvas.buffer_rgba())).convert("RGB")
        image = image.crop((int(left * dpi), int((height - top) * dpi),
                            int(np.ceil(right * dpi)), int(np.ceil((height - bottom) * dpi))))
    else:  # one more drawing, into the box that holds everything
        buffer = io.BytesIO()
        figure.savefig(buffer, format="png", bbox_inches=box.padded(0.1))
        image = Image.open(io.BytesIO(buffer.getvalue())).convert("RGB")
    quantized = image.quantize(colors=colours, method=Image.Quantize.FASTOCTREE, dither=Image.Dither.NONE)
    out = io.BytesIO()
    quantized.save(out, format="PNG")
    return out.getvalue()


#: The draw function and the grid points of the rendering under way; forked workers
#: inherit them (nothing is pickled but the point's number and the PNG that comes back).
_job: tuple[Callable[..., object], list[dict]] | None = None


def _render_point(number: int) -> tuple[bytes, str]:
    """PNG and printed text of grid point ``number`` of the rendering under way (see :data:`_job`)."""
    draw, points = _job
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
    image = _png(figure)
    plt.close(figure)
    return image, printed.getvalue()


def render_grid(draw: Callable[..., object], controls: Sequence[StaticControl],
                workers: int | None = None) -> StaticPanel:
    """Call ``draw`` at every point of the controls' grid; keep each figure (PNG) and what it printed.

    ``draw`` must make exactly one new figure per call (it is closed after it is stored).
    The points are shared out over ``workers`` forked processes (default: one per core;
    1: in this process, as ``draw`` must be when it starts process pools itself); the
    result is the same either way. Raises :class:`~pfcourse.errors.ParameterError`
    naming the grid point where ``draw`` made no figure or several.
    """
    global _job
    names = [c.name for c in controls]
    points = [dict(zip(names, point)) for point in itertools.product(*(c.values for c in controls))]
    workers = min(workers or os.cpu_count() or 1, len(points))
    _job = (draw, points)
    try:
        if workers < 2:
            rendered = [_render_point(k) for k in range(len(points))]
        else:  # forked workers inherit _job; a pool that stalls is replaced by this process
            rendered = run_tasks(_render_point, [(k,) for k in range(len(points))], workers=workers,
                                 stall_timeout=POOL_TIMEOUT)
    finally:
        _job = None
    return StaticPanel(tuple(controls), tuple(r[0] for r in rendered), tuple(r[1] for r in rendered))


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
    gridded = [c for c in panel.controls if c.enabled]
    strides, current = panel.strides, panel.current
    uris = ["data:image/png;base64," + base64.b64encode(image).decode("ascii") for image in panel.images]
    data = {
        "controls": [c.name for c in panel.controls],
        "strides": strides,
        "enabled": [c.enabled for c in panel.controls],
        "labels": [[format_value(v) for v in c.values] for c in panel.controls],
        "texts": list(panel.texts),
        "images": uris,
    }
    controls = "".join(_control_html(c) for c in panel.controls)
    text = panel.texts[current]
    printed = f'<pre class="pfcourse-panel-text">{html.escape(text)}</pre>' if any(panel.texts) else ""
    points = len(panel.images)
    note = (f'<p class="pfcourse-panel-note">{points} figures over {len(gridded)} control'
            f'{"s" if len(gridded) != 1 else ""}. {LIVE_NOTE}</p>')
    payload = json.dumps(data, separators=(",", ":")).replace("</", "<\\/")
    return (f'<div class="pfcourse-panel" data-current="{current}">'
            f'<div class="pfcourse-panel-controls">{controls}</div>{note}{printed}'
            f'<img class="pfcourse-panel-figure" alt="{html.escape(alt)}" src="{uris[current]}">'
            f'<script type="application/json" class="pfcourse-panel-data">{payload}</script></div>')


def static_controls(values: Mapping[str, object], descriptions: Mapping[str, str],
                    kinds: Mapping[str, str], grid: Mapping[str, Sequence]) -> tuple[StaticControl, ...]:
    """The controls of a static panel: gridded ones with their values, the others fixed at ``values``.

    Raises :class:`~pfcourse.errors.ParameterError` when the grid names an unknown control,
    lists no value, or does not contain a control's current value (the page must open on a
    figure of the grid).
    """
    unknown = set(grid) - set(values)
    if unknown:
        raise ParameterError(f"panel grid names controls the panel does not have: {sorted(unknown)}")
    controls = []
    for name, value in values.items():
        if name in grid:
            options = tuple(grid[name])
            if not options:
                raise ParameterError(f"panel grid of {name!r} lists no value")
            if value not in options:
                raise ParameterError(f"panel grid of {name!r} does not contain its current value {value!r}: {options}")
            controls.append(StaticControl(name, descriptions[name], options, options.index(value), kinds[name], True))
        else:
            controls.append(StaticControl(name, descriptions[name], (value,), 0, kinds[name], False))
    return tuple(controls)
