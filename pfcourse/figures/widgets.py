"""Widget panels: controls that re-run a computation and redraw its figure.

Every chapter's panel is built the same way: a ``draw(**values)`` function that
makes one figure from the control values, and a dictionary of controls::

    panel = control_panel(draw, n_particles=particle_slider(), seed=seed_box())
    display(panel)

In JupyterLab moving a control calls ``draw`` again; in the static HTML book the
panel shows its saved state, so chapters also show a static figure of the
default values.  Tag the cell ``nbval-ignore-output``: widget outputs are not
reproducible text.
"""

from __future__ import annotations

from collections.abc import Callable

import ipywidgets as widgets
import matplotlib.pyplot as plt

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


def control_panel(draw: Callable[..., None], columns: int = 3, **controls: widgets.ValueWidget) -> widgets.VBox:
    """Controls in a grid above the figure that ``draw(**values)`` makes; redrawn on every change.

    The grid has at most ``columns`` columns and wraps to fewer on a narrow page
    (:func:`control_grid_columns`); each control fills its grid cell.
    """
    global _last_panel
    _last_panel = (draw, controls)

    def redraw(**values) -> None:
        draw(**values)
        plt.show()

    for control in controls.values():
        control.layout.width = "auto"  # fill the grid cell rather than overflow it at a fixed 300 px
        style = getattr(control, "style", None)
        if style is not None and hasattr(style, "description_width") and not style.description_width:
            style.description_width = "initial"  # the whole description, not cut at 80 px
    output = widgets.interactive_output(redraw, controls)
    grid = widgets.GridBox(
        list(controls.values()),
        layout=widgets.Layout(grid_template_columns=control_grid_columns(columns), grid_gap="4px 8px"),
    )
    return widgets.VBox([grid, output])
