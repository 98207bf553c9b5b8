"""Widget panels call their draw function with the current control values."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from pfcourse.book.panels import (  # noqa: E402
    control_panel,
    particle_slider,
    scale_slider,
    scheme_dropdown,
    seed_box,
    threshold_slider,
)


def recorder(calls):
    """A draw function that records its values and makes the one figure a panel needs."""
    def draw(**values):
        calls.append(values)
        plt.figure()
    return draw


def test_panel_redraws_with_the_new_values():
    calls = []
    n, seed = particle_slider(100), seed_box(3)
    panel = control_panel(recorder(calls), workers=1, n_particles=n, seed=seed)
    assert calls[0] == {"n_particles": 100, "seed": 3}  # the static figure, also the live panel's first
    # then each other value of each control, one factor at a time (the HTML book's figures)
    assert all(sum(c[k] != calls[0][k] for k in c) == 1 for c in calls[1:])
    assert {c["seed"] for c in calls} == {3, 4, 5} and len({c["n_particles"] for c in calls}) == 4
    before = len(calls)
    n.value = 1000  # a value the panel drew when it was built: that figure again, no new drawing
    assert {"n_particles": 1000, "seed": 3} in calls and len(calls) == before
    seed.value = 99  # off the grid: drawn live with the new values
    assert calls[-1] == {"n_particles": 1000, "seed": 99} and len(calls) == before + 1
    assert len(panel.widget.children) == 2
    plt.close("all")


def test_control_defaults_and_ranges():
    assert 10 in particle_slider().options and 10000 in particle_slider().options
    assert 300 in particle_slider(300).options
    assert (threshold_slider().min, threshold_slider().max) == (0.0, 1.0)
    assert set(scheme_dropdown().options) == {"multinomial", "stratified", "systematic", "residual"}
    s = scale_slider("QEst scale")
    assert s.value == 1.0 and s.min == -1 and s.max == 1


def test_redraw_last_panel_uses_the_current_values():
    from pfcourse.book.panels import redraw_last_panel

    calls = []
    threshold = threshold_slider(0.3)
    control_panel(recorder(calls), workers=1, threshold=threshold)
    threshold.value = 0.8
    calls.clear()
    redraw_last_panel()
    assert calls == [{"threshold": 0.8}]
    plt.close("all")


def test_controls_fill_their_cells_and_the_grid_wraps_on_narrow_pages():
    n, threshold = particle_slider(100), threshold_slider(0.3)
    panel = control_panel(recorder([]), columns=3, workers=1, n_particles=n, threshold=threshold)
    columns = panel.widget.children[0].layout.grid_template_columns
    assert columns.startswith("repeat(auto-fill, minmax(max(280px,")  # never narrower than a slider needs
    assert "/ 3)" in columns  # and at most three columns on a wide page
    assert n.layout.width == threshold.layout.width == "auto"
    assert n.style.description_width == "initial"
