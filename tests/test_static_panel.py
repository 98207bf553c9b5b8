"""Static panels: the figures of a grid of control values, switched in the HTML book without a kernel.

Checked here: the grid is rendered in row-major order (the order the page's script
indexes), the same with one process or several, the page opens on the figure of the
controls' current values, controls outside the grid are disabled, bad grids and bad
draw functions are refused with a named error, and every chapter's stored panel
offers at least two controls with at least three values (issue 19).
"""

from __future__ import annotations

import base64
import io
import json
import re
from pathlib import Path

import ipywidgets as widgets
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import nbformat  # noqa: E402
import pytest  # noqa: E402
from PIL import Image  # noqa: E402

from pfcourse.errors import ParameterError  # noqa: E402
from pfcourse.book.static_panel import panel_html, render_grid, static_controls  # noqa: E402
from pfcourse.book.panels import Panel, control_panel  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def draw_bars(a, b, c):
    """One figure whose bar heights are the values; prints the values."""
    fig, ax = plt.subplots(figsize=(3, 2))
    ax.bar([0, 1, 2], [a, b, c])
    print(f"a={a} b={b} c={c}")


def controls_abc(grid, a=2, b=10, c=0.5):
    return static_controls({"a": a, "b": b, "c": c}, {"a": "a", "b": "b", "c": "c"},
                           {"a": "range", "b": "select", "c": "range"}, grid)


def test_grid_is_row_major_and_keeps_what_draw_printed():
    controls = controls_abc({"a": (1, 2, 3), "b": (10, 20)})
    panel = render_grid(draw_bars, controls, workers=1)
    assert len(panel.images) == 6
    expected = [f"a={a} b={b} c=0.5\n" for a in (1, 2, 3) for b in (10, 20)]
    assert list(panel.texts) == expected
    assert panel.strides == [2, 1, 0]  # c, outside the grid, stays at its value
    assert panel.current == 1 * 2 + 0  # a = 2 is index 1, b = 10 index 0
    assert panel.texts[panel.current] == "a=2 b=10 c=0.5\n"
    assert plt.get_fignums() == []  # every figure closed


def test_images_differ_between_points_and_are_palette_pngs():
    panel = render_grid(draw_bars, controls_abc({"a": (1, 3)}, a=1), workers=1)
    first, second = (Image.open(io.BytesIO(b)) for b in panel.images)
    assert first.format == "PNG" and first.mode == "P"  # at most 256 colours
    assert panel.images[0] != panel.images[1]
    assert first.size[0] <= 3 * 100 and first.size[1] <= 2 * 100  # cropped, never larger than the figure


def test_forked_workers_give_the_same_figures():
    controls = controls_abc({"a": (1, 2, 3), "b": (10, 20)})
    serial = render_grid(draw_bars, controls, workers=1)
    forked = render_grid(draw_bars, controls, workers=2)
    assert serial == forked


def test_html_opens_on_the_current_figure_and_disables_the_rest():
    panel = render_grid(draw_bars, controls_abc({"a": (1, 2, 3), "b": (10, 20)}), workers=1)
    page = panel_html(panel)
    data = json.loads(re.search(r'<script type="application/json" class="pfcourse-panel-data">(.*?)</script>',
                                page).group(1))
    current_uri = data["images"][panel.current]
    assert f'src="{current_uri}"' in page
    assert base64.b64decode(current_uri.split(",", 1)[1]) == panel.images[panel.current]
    assert data["strides"] == panel.strides
    assert data["enabled"] == [True, True, False]
    assert re.search(r'<input type="range" name="a" min="0" max="2" step="1" value="1">', page)
    assert '<option value="0" selected>10</option>' in page
    assert re.search(r'<input type="text" value="0.5" disabled>', page)  # c: not in the grid
    assert "live in JupyterLab" in page


@pytest.mark.parametrize("grid, message", [
    ({"d": (1,)}, "does not have: \\['d'\\]"),
    ({"a": ()}, "lists no value"),
    ({"a": (1, 3)}, "does not contain its current value 2"),
])
def test_bad_grids_are_named(grid, message):
    with pytest.raises(ParameterError, match=message):
        controls_abc(grid)


def test_a_draw_that_makes_no_figure_is_named_with_its_point():
    def draw_nothing(a, b, c):
        if a == 3:
            return
        draw_bars(a, b, c)

    with pytest.raises(ParameterError, match="at {'a': 3, 'b': 10, 'c': 0.5} it made 0"):
        render_grid(draw_nothing, controls_abc({"a": (1, 3)}, a=1), workers=1)
    assert plt.get_fignums() == []


def test_control_panel_carries_the_widget_and_the_static_page():
    panel = control_panel(draw_bars, grid={"a": (1, 2)}, workers=1,
                          a=widgets.IntSlider(value=2, min=0, max=5, description="a"),
                          b=widgets.Dropdown(options=[10, 20], value=10, description="b"),
                          c=widgets.FloatSlider(value=0.5, description="c"))
    assert isinstance(panel, Panel)
    bundle = panel._repr_mimebundle_()
    assert "application/vnd.jupyter.widget-view+json" in bundle
    assert bundle["text/html"].startswith('<div class="pfcourse-panel"')
    assert [c.enabled for c in panel.static.controls] == [True, True, True]  # no greyed control (issue 33)
    assert [c.main for c in panel.static.controls] == [True, False, False]
    assert panel.static.controls[1].values == (10, 20) and panel.static.controls[2].values == (0.0, 0.5, 100.0)
    # the live panel redraws on a change (the widget's Output gets a new figure)
    panel.widget.children[0].children[0].value = 1


def test_the_book_prefers_the_static_page_to_the_widget_view():
    config = (ROOT / "_config.yml").read_text()
    assert "nb_mime_priority_overrides: [[html, text/html, 5]]" in config  # widget views rank 10
    assert "pfcourse-panels.js" in config
    assert (ROOT / "web" / "static" / "pfcourse-panels.js").exists()


def stored_panels():
    for path in sorted((ROOT / "book").rglob("*.ipynb")):
        if "control_panel(" not in path.with_suffix(".py").read_text(encoding="utf-8"):
            continue
        nb = nbformat.read(path, as_version=4)
        pages = [o["data"]["text/html"] for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", [])
                 if "text/html" in o.get("data", {}) and 'class="pfcourse-panel"' in o["data"]["text/html"]]
        yield path.relative_to(ROOT).as_posix(), nb, pages


@pytest.mark.parametrize("chapter, nb, pages", list(stored_panels()), ids=lambda v: v if isinstance(v, str) else "")
def test_every_stored_panel_offers_two_controls_with_three_values(chapter, nb, pages):
    assert len(pages) == 1, f"{chapter}: one panel expected, found {len(pages)}"
    data = json.loads(re.search(r'class="pfcourse-panel-data">(.*?)</script>', pages[0]).group(1))
    sizes = sorted((len(labels) for labels, on in zip(data["labels"], data["enabled"]) if on), reverse=True)
    assert len(sizes) >= 2 and sizes[1] >= 3, f"{chapter}: grid {sizes}"
    # at least one figure for each value of each control, the others at the values the page opens with
    assert len(data["images"]) >= 1 + sum(size - 1 for size in sizes), f"{chapter}: {len(data['images'])} figures"
    greyed = [d for d, on in zip(data["descriptions"], data["enabled"]) if not on]
    assert not greyed, f"{chapter}: controls that do not move the figure in the HTML book: {greyed} (issue 33)"
    assert not [d for d in data["descriptions"] if "_" in d], f"{chapter}: a label in code, not words"
    assert "widgets" not in nb.metadata  # no widget state: the HTML book loads no widget manager


def test_a_pool_that_does_not_answer_is_replaced_by_the_serial_path(monkeypatch):
    """A forked worker that hangs (a lock held at fork time) must not hang the chapter."""
    import os
    import time

    from pfcourse.studies.executor import StudyWarning
    from pfcourse.book import static_panel

    parent = os.getpid()

    def draw_slow_in_workers(a, b, c):
        if os.getpid() != parent:
            time.sleep(30)
        draw_bars(a, b, c)

    monkeypatch.setattr(static_panel, "POOL_TIMEOUT", 2.0)
    controls = controls_abc({"a": (1, 2, 3)})
    start = time.perf_counter()
    with pytest.warns(StudyWarning, match="finished in 2 s"):
        panel = render_grid(draw_slow_in_workers, controls, workers=2)
    assert time.perf_counter() - start < 20
    assert panel == render_grid(draw_bars, controls, workers=1)


def test_side_controls_are_drawn_one_factor_at_a_time():
    controls = static_controls({"a": 2, "b": 10, "c": 0.5}, {"a": "a", "b": "b", "c": "c"},
                               {"a": "range", "b": "select", "c": "range"}, {"a": (1, 2, 3)},
                               side={"b": (10, 20, 30), "c": (0.5,)})
    panel = render_grid(draw_bars, controls, workers=1)
    assert [c.enabled for c in panel.controls] == [True, True, False]  # c offers one value: shown disabled
    assert len(panel.images) == 3 + 2 and panel.grid_size == 3
    assert panel.strides == [1, 0, 0]
    assert panel.side[1] == {0: panel.current, 1: 3, 2: 4}  # b = 10 is the grid's figure at the defaults
    assert panel.texts[3] == "a=2 b=20 c=0.5\n" and panel.texts[4] == "a=2 b=30 c=0.5\n"
    page = panel_html(panel)
    data = json.loads(re.search(r'<script type="application/json" class="pfcourse-panel-data">(.*?)</script>',
                                page).group(1))
    assert data["main"] == [True, False, False] and data["defaults"] == [1, 0, 0]
    assert data["side"]["1"] == [panel.current, 3, 4]
    assert '<p class="pfcourse-panel-nearest" hidden></p>' in page
    assert "5 figures: each value of a, and each value of b with the other controls" in page
    with pytest.raises(ParameterError, match="both in the grid and in the side values"):
        static_controls({"a": 2}, {"a": "a"}, {"a": "range"}, {"a": (1, 2)}, side={"a": (1, 2)})
    with pytest.raises(ParameterError, match="side values of 'b' does not contain its current value 10"):
        static_controls({"b": 10}, {"b": "b"}, {"b": "select"}, {}, side={"b": (20, 30)})


def test_values_read_as_a_reader_writes_them():
    from pfcourse.book.static_panel import format_value

    assert [format_value(v) for v in (1 / 3, 2 / 3, 0.25, 0.1, 0.5, 1.0, 1e-5, 1000)] == \
        ["1/3", "2/3", "0.25", "0.1", "0.5", "1", "1e-05", "1000"]
    assert format_value((0.0, 6.0)) == "0–6"


def test_offered_values_cover_every_kind_of_control():
    from pfcourse.book.panels import offered_values, particle_slider, readable, scale_slider, seed_box

    assert offered_values(widgets.Checkbox(value=False)) == (False, True)
    assert offered_values(widgets.FloatSlider(value=0.5, min=0.0, max=1.0, step=0.05)) == (0.0, 0.5, 1.0)
    assert offered_values(widgets.FloatSlider(value=0.0, min=0.0, max=1.0, step=0.05)) == (0.0, 0.5, 1.0)
    assert offered_values(widgets.IntSlider(value=3, min=1, max=9)) == (1, 3, 9)
    assert offered_values(scale_slider("s")) == pytest.approx((0.1, 1.0, 10.0))
    assert offered_values(seed_box(7)) == (7, 8, 9)
    values = offered_values(particle_slider(300))
    assert 300 in values and values[0] == 10 and values[-1] == 10000 and len(values) <= 5
    assert offered_values(widgets.Text(value="x")) == ("x",)
    assert readable("n_particles", "n_particles") == "particles N" and readable("dt_meas", None) == "dt meas"
    assert readable("x", "my words") == "my words"
