"""Widget panels: controls that re-run a computation and redraw its figure.

Every chapter's panel is built the same way: a ``draw(**values)`` function that
makes one figure from the control values, a dictionary of controls, and the grid of
values the HTML book offers without a kernel::

    panel = control_panel(draw, grid={"n_particles": (10, 100, 1000)},
                          n_particles=particle_slider(), seed=seed_box())
    display(panel)

In JupyterLab the panel is live: moving a control calls ``draw`` again.  The same
output also carries a static version (:mod:`pfcourse.book.static_panel`): the
figures of every grid point, and of a few values of every other control one factor at a
time (:func:`offered_values`, or the chapter's ``side=``), which the HTML book switches
between in the browser (the book prefers ``text/html`` to the widget view, ``_config.yml``),
so that every control the page shows moves its figure.  Tag the cell
``nbval-ignore-output``: widget outputs are not reproducible text.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

import ipywidgets as widgets
import matplotlib.pyplot as plt
from IPython.display import Image, display

from pfcourse.book import narrow_figures
from pfcourse.book.static_panel import StaticPanel, panel_html, render_grid, static_controls
from pfcourse.resampling import SCHEMES

_STYLE = {"description_width": "initial"}


def particle_slider(value: int = 1000, low_exponent: int = 1, high_exponent: int = 4) -> widgets.IntSlider:
    """Number of particles N, on a slider of powers of ten and their halves."""
    options = sorted({m * 10**e for e in range(low_exponent, high_exponent + 1) for m in (1, 2, 5)})
    options = [o for o in options if o <= 10**high_exponent]
    if value not in options:
        options = sorted(set(options) | {value})
    return widgets.SelectionSlider(options=options, value=value, description="particles N", style=_STYLE)


def threshold_slider(value: float = 0.5) -> widgets.FloatSlider:
    """Resampling threshold: resample when ESS < threshold x N (0 = SIS)."""
    return widgets.FloatSlider(value=value, min=0.0, max=1.0, step=0.05, description="threshold", style=_STYLE)


def scheme_dropdown(value: str = "systematic") -> widgets.Dropdown:
    """Resampling scheme."""
    return widgets.Dropdown(options=list(SCHEMES), value=value, description="scheme", style=_STYLE)


def scale_slider(description: str, value: float = 1.0) -> widgets.FloatLogSlider:
    """A multiplicative factor from 0.1 to 10 on a log scale (noise scales)."""
    return widgets.FloatLogSlider(value=value, base=10, min=-1, max=1, step=0.1, description=description, style=_STYLE)


def seed_box(value: int = 0) -> widgets.BoundedIntText:
    """Seed of the random-number generator: the same seed gives the same run."""
    return widgets.BoundedIntText(value=value, min=0, max=2**31 - 1, description="seed", style=_STYLE)


_last_panel: tuple[Callable[..., None], dict[str, widgets.ValueWidget]] | None = None


def redraw_last_panel() -> None:
    """Call the most recent panel's ``draw`` with its controls' current values (for timing a widget update)."""
    if _last_panel is None:
        raise RuntimeError("no control panel has been built in this session")
    draw, controls = _last_panel
    draw(**{name: control.value for name, control in controls.items()})


#: Narrowest grid column (CSS px): room for a control's description, a usable slider track and
#: its readout side by side (ipywidgets draws a slider 300 px wide unless told otherwise).
MIN_COLUMN_WIDTH = 280


def control_grid_columns(columns: int, min_width: int = MIN_COLUMN_WIDTH) -> str:
    """CSS ``grid-template-columns``: at most ``columns`` equal columns, none narrower than ``min_width`` px.

    ``auto-fill`` drops to fewer columns (down to one) when the page is narrow,
    instead of squeezing the controls until a readout overlaps the next label.
    """
    return f"repeat(auto-fill, minmax(max({min_width}px, calc((100% - {columns - 1} * 8px) / {columns})), 1fr))"


def _spread(options: Sequence, current, count: int) -> tuple:
    """At most ``count`` of ``options``, evenly spread, always with the first, the last and ``current``."""
    options = list(options)
    if len(options) <= count:
        return tuple(options)
    picks = {round(i * (len(options) - 1) / (count - 1)) for i in range(count)}
    picks.add(options.index(current))
    return tuple(options[i] for i in sorted(picks))


def offered_values(control: widgets.ValueWidget, count: int = 3) -> tuple:
    """The values the HTML book offers for a control outside the main grid, one factor at a time.

    Options of a drop-down or a selection slider (at most ``count`` + 1, spread over the list),
    both states of a check box, the ends and the current value of a numeric slider (on a log
    slider, of its exponent), and three consecutive seeds from the current one for an integer
    box; a control of another kind offers its current value only.
    """
    value = control.value
    if isinstance(control, (widgets.Dropdown, widgets.SelectionSlider, widgets.RadioButtons, widgets.ToggleButtons,
                            widgets.Select)):
        options = [o[1] if isinstance(o, tuple) else o for o in control.options]
        return _spread(options, value, count + 1)
    if isinstance(control, (widgets.Checkbox, widgets.ToggleButton)):
        return (value, not value)
    if isinstance(control, widgets.FloatLogSlider):
        ends = [float(control.base ** control.min), float(control.base ** control.max)]
        return tuple(sorted({ends[0], value, ends[1]}))
    if isinstance(control, (widgets.IntSlider, widgets.FloatSlider)):
        values = {control.min, value, control.max}
        if len(values) < 3:  # the current value is an end: add the middle, on the slider's step
            middle = control.min + round((control.max - control.min) / 2 / control.step) * control.step
            values.add(type(value)(middle))
        return tuple(sorted(values))
    if isinstance(control, (widgets.BoundedIntText, widgets.IntText)):
        top = getattr(control, "max", value + count - 1)
        return tuple(v for v in range(value, value + count) if v <= top)
    return (value,)


#: Names the panels use, as the page shows them when a control has no description of its own.
READABLE_NAMES = {"n_particles": "particles N", "threshold": "resampling threshold", "n_runs": "runs",
                  "seed": "seed", "scheme": "resampling scheme"}


def readable(name: str, description: str | None) -> str:
    """A control's label in words: its description, else a readable version of its name."""
    if description and description != name:
        return description
    return READABLE_NAMES.get(name, name.replace("_", " "))


#: Widget types the static page shows as a slider over the grid's values (others: a drop-down).
_RANGE_TYPES = (widgets.SelectionSlider, widgets.FloatSlider, widgets.IntSlider, widgets.FloatLogSlider,
                widgets.IntRangeSlider, widgets.FloatRangeSlider, widgets.SelectionRangeSlider)


class Panel:
    """A live widget panel (``widget``) and its static version over a grid (``static``).

    Displayed, it is one output with two representations: the widget view (JupyterLab
    renders it, live) and ``text/html`` (the HTML book renders it, no kernel needed).
    """

    def __init__(self, widget: widgets.VBox, static: StaticPanel, alt: str) -> None:
        self.widget = widget
        self.static = static
        self.html = panel_html(static, alt)

    def _repr_mimebundle_(self, **kwargs) -> dict:
        bundle = self.widget._repr_mimebundle_(**kwargs)
        bundle["text/html"] = self.html
        return bundle


def control_panel(draw: Callable[..., None], columns: int = 3, grid: Mapping[str, Sequence] | None = None,
                  alt: str = "the panel's figure", workers: int | None = None,
                  side: Mapping[str, Sequence] | None = None, **controls: widgets.ValueWidget) -> Panel:
    """Controls in a grid above the figure that ``draw(**values)`` makes; redrawn on every change.

    The grid has at most ``columns`` columns and wraps to fewer on a narrow page
    (:func:`control_grid_columns`); each control fills its grid cell.  ``grid`` lists,
    for the controls the HTML book should offer, the values it offers (each list must
    contain the control's current value); the figures of every combination are made
    now (:func:`~pfcourse.book.static_panel.render_grid`, over ``workers`` processes),
    and the one at the current values is the live panel's first figure. Every other
    control offers the values ``side`` lists for it (default :func:`offered_values`), each
    drawn with the other controls at their current values.  A change to values the panel
    already drew shows that figure again (:meth:`StaticPanel.image_of`), at once; any other
    value is drawn live.
    """
    global _last_panel
    _last_panel = (draw, controls)

    grid = dict(grid or {})
    descriptions = {name: readable(name, control.description) for name, control in controls.items()}
    kinds = {name: "range" if isinstance(control, _RANGE_TYPES) else "select" for name, control in controls.items()}
    side = {name: tuple((side or {}).get(name, offered_values(control))) for name, control in controls.items()
            if name not in grid}
    static = render_grid(draw, static_controls({n: c.value for n, c in controls.items()}, descriptions,
                                               kinds, grid, side), workers)
    current = static.current

    for name, control in controls.items():
        control.description = descriptions[name]  # the words the static page shows, live too
        control.layout.width = "auto"  # fill the grid cell rather than overflow it at a fixed 300 px
        style = getattr(control, "style", None)
        if style is not None and hasattr(style, "description_width") and not style.description_width:
            style.description_width = "initial"  # the whole description, not cut at 80 px
    output = widgets.Output()

    def redraw(change=None) -> None:
        values = {name: control.value for name, control in controls.items()}
        number = static.image_of(values)  # a point of the grid: the figure drawn for it when the panel was built
        with output, narrow_figures.without_narrow_copies():
            output.clear_output(wait=True)
            if number is None:
                draw(**values)
                plt.show()
            else:
                if static.texts[number]:
                    print(static.texts[number], end="")
                display(Image(data=static.images[number], format="png"))

    for control in controls.values():
        control.observe(redraw, names="value")
    with output:
        if static.texts[current]:
            print(static.texts[current], end="")
        display(Image(data=static.images[current], format="png"))
    grid_box = widgets.GridBox(
        list(controls.values()),
        layout=widgets.Layout(grid_template_columns=control_grid_columns(columns), grid_gap="4px 8px"),
    )
    return Panel(widgets.VBox([grid_box, output]), static, alt)

