"""A live panel shows the figure it drew when it was built for any point of its grid, and draws live otherwise.

`StaticPanel.image_of` maps the controls' values to the figure made for them: every main-grid point, a side
control's other values with every other control at its default, nothing else."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
import pytest
from ipywidgets import Dropdown, IntSlider

from pfcourse.book.panels import control_panel

CALLS: list[tuple] = []


@pytest.fixture(autouse=True)
def no_figure_left():
    yield
    plt.close("all")  # the live drawing's figure (plt.show does not close it outside a notebook)


def draw(a, b, c):
    CALLS.append((a, b, c))
    fig, ax = plt.subplots(figsize=(2, 1.5))
    ax.plot(np.arange(5) * a + b, np.arange(5) * c)


def make_panel():
    return control_panel(draw, grid={"a": (1.0, 2.0, 3.0), "b": (0, 1)}, workers=1,
                         a=Dropdown(options=[1.0, 2.0, 3.0], value=2.0), b=Dropdown(options=[0, 1], value=1),
                         c=IntSlider(value=2, min=1, max=4))


def test_image_of_numbers_every_figure_once_and_nothing_else():
    panel = make_panel()
    static = panel.static
    numbers = {static.image_of({"a": a, "b": b, "c": 2}) for a in (1.0, 2.0, 3.0) for b in (0, 1)}
    assert numbers == set(range(static.grid_size)) == set(range(6))
    side = {static.image_of({"a": 2.0, "b": 1, "c": c}) for c in static.controls[2].values}
    assert None not in side and len(side) == len(static.controls[2].values)
    assert side & numbers == {static.current}  # the side control's default is the grid's current figure
    assert len(numbers | side) == len(static.images)
    other = next(v for v in static.controls[2].values if v != 2)
    assert static.image_of({"a": 1.0, "b": 0, "c": other}) is None  # a side value, the others off default
    assert static.image_of({"a": 2.5, "b": 1, "c": 2}) is None  # not a grid value: drawn live
    assert static.image_of({"a": 2.0, "b": True, "c": 2}) is None  # True is not the value 1 here


def test_a_change_to_a_grid_point_shows_its_figure_without_drawing_again():
    panel = make_panel()
    static = panel.static
    controls = [child for child in panel.widget.children[0].children]
    a = next(w for w in controls if isinstance(w, Dropdown) and w.options == (1.0, 2.0, 3.0))
    slider = next(w for w in controls if isinstance(w, IntSlider))
    CALLS.clear()
    a.value = 3.0
    assert CALLS == []  # the grid's figure, not a new drawing
    assert static.image_of({"a": 3.0, "b": 1, "c": 2}) is not None
    off_grid = next(v for v in range(slider.min, slider.max + 1) if v not in static.controls[2].values)
    slider.value = off_grid
    assert CALLS == [(3.0, 1, off_grid)]  # off the grid: drawn live
