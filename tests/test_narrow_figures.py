"""Narrow copies of wide figures for phones (pfcourse/book/narrow_figures.py, issue 33).

Checked here: which figures need a copy (the arithmetic of a text scaled to the phone's column);
the copy stacks side-by-side axes in one column, in reading order, at the phone's width, with
the text at its natural size, a colour bar beside its axes and a legend outside the axes moved
under it; the figure shown is left as it was (size, positions, pyplot's figures); the one-drawing
tight PNG is the box ``savefig(bbox_inches="tight")`` saves; a figure's display data carry the
copy in a ``<picture>`` only when it needs one; a static panel of wide figures carries copies.
"""

from __future__ import annotations

import base64
import io
import json
import re

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from PIL import Image  # noqa: E402

from pfcourse.book import narrow_figures as nf  # noqa: E402
from pfcourse.book.static_panel import panel_html, render_grid, static_controls  # noqa: E402
from pfcourse.book.style import STYLE  # noqa: E402


@pytest.fixture(autouse=True)
def book_style():
    with matplotlib.rc_context(STYLE):
        yield
    plt.close("all")


def three_panels(legend_outside: bool = False, sharey: bool = False):
    fig, axes = plt.subplots(1, 3, figsize=(10, 3.5), sharey=sharey)
    for k, ax in enumerate(axes):
        ax.plot(np.arange(20), np.arange(20) * (k + 1), label=f"line {k}")
        ax.set_xlabel("time t (s)")
        ax.set_ylabel("error (m)")
        ax.set_title(f"panel {k}")
    if legend_outside:
        axes[2].legend(loc="upper left", bbox_to_anchor=(1.02, 1))
    fig.tight_layout()
    return fig, axes


def test_a_copy_is_needed_when_the_text_scaled_to_the_column_falls_under_8_px():
    # 12.5 px (9 pt at 100 dpi) text: readable scaled to 388 px from at most 388 * 12.5 / 8 = 606 px
    assert not nf.needs_narrow_copy(600, 12.5)
    assert nf.needs_narrow_copy(610, 12.5)
    assert not nf.needs_narrow_copy(380, 8.0)  # not enlarged, so a narrow figure's 8 px stay 8 px
    assert nf.needs_narrow_copy(380, 7.9)


def test_the_copy_stacks_the_axes_in_reading_order_at_the_phones_width():
    fig, axes = three_panels()
    size, positions = fig.get_size_inches().copy(), [ax.get_position().bounds for ax in axes]
    figures = plt.get_fignums()
    copy = nf.narrow_copy(fig)
    boxes = [ax.get_position() for ax in copy.axes]
    assert len(boxes) == 3
    assert all(abs(b.x0 - boxes[0].x0) < 1e-9 and abs(b.width - boxes[0].width) < 1e-9 for b in boxes)
    assert boxes[0].y0 > boxes[1].y1 and boxes[1].y0 > boxes[2].y1  # panel 0 on top, then 1, then 2
    assert [ax.get_title() for ax in copy.axes] == ["panel 0", "panel 1", "panel 2"]
    png = nf._print_png(copy)[0]
    assert nf.png_width(png) <= nf.PHONE_COLUMN_PX  # shown at its natural size: text unscaled
    assert nf.smallest_font_px(copy, copy.dpi) >= nf.MIN_TEXT_PX
    # the figure shown is untouched, and the copy is not left among pyplot's figures
    assert np.allclose(fig.get_size_inches(), size)
    assert [ax.get_position().bounds for ax in axes] == positions
    assert plt.get_fignums() == figures and plt.gcf() is fig


def test_no_text_of_the_copy_is_cut_or_drawn_over_another():
    from pfcourse.book.legibility import overlapping_texts

    fig, _ = three_panels(legend_outside=True, sharey=True)
    copy = nf.narrow_copy(fig)
    assert overlapping_texts(copy) == []
    legend = copy.axes[2].get_legend()
    copy.canvas.draw()
    renderer = copy.canvas.get_renderer()
    under = legend.get_window_extent(renderer)
    axes_box = copy.axes[2].get_window_extent(renderer)
    assert under.y1 < axes_box.y0  # the legend right of the axes went under it
    assert nf.png_width(nf._print_png(copy)[0]) <= nf.PHONE_COLUMN_PX
    # the shared y axis's tick labels are back on the panels that were right of the first
    assert all(label.get_visible() for label in copy.axes[1].get_yticklabels())


def test_a_colour_bar_moves_with_its_axes():
    fig, axes = plt.subplots(1, 2, figsize=(9, 4))
    for ax in axes:
        fig.colorbar(ax.imshow(np.arange(12.0).reshape(3, 4)), ax=ax, label="height (m)")
    copy = nf.narrow_copy(fig)
    maps = [ax for ax in copy.axes if ax.get_label() != "<colorbar>"]
    bars = [ax for ax in copy.axes if ax.get_label() == "<colorbar>"]
    assert len(maps) == 2 and len(bars) == 2
    for image_axes, bar in zip(maps, bars):
        a, b = image_axes.get_position(), bar.get_position()
        assert b.x0 >= a.x1 - 1e-9 and b.y0 < a.y1 and b.y1 > a.y0  # beside its own map, at its height
    assert maps[0].get_position().y0 > maps[1].get_position().y1
    assert nf.png_width(nf._print_png(copy)[0]) <= nf.PHONE_COLUMN_PX


def test_panels_cut_from_the_drawing_are_stacked_in_reading_order():
    fig, axes = three_panels()
    drawing = nf.tight_drawing(fig)
    whole = drawing[0]
    stack = nf.sliced_image(fig, drawing)
    assert stack is not None
    assert stack.width <= nf.PHONE_COLUMN_PX and stack.width < whole.width / 2
    assert whole.height * 2.5 < stack.height <= whole.height * 3.5
    # the first piece is the first panel with its labels, pixel for pixel, at the top of the stack
    canvas = Image.fromarray(np.asarray(fig.canvas.buffer_rgba())).convert("RGB")
    box, pad = axes[0].get_tightbbox(fig.canvas.get_renderer()), 0.05 * fig.dpi
    piece = canvas.crop((int(box.x0 - pad), int(canvas.height - box.y1 - pad),
                         int(np.ceil(box.x1 + pad)), int(np.ceil(canvas.height - box.y0 + pad))))
    assert drawing[1] == (int(fig.get_tightbbox().x0 * fig.dpi - 10), int(canvas.height - fig.get_tightbbox().y1 * fig.dpi - 10))
    left = (stack.width - piece.width) // 2
    assert np.array_equal(np.asarray(stack.crop((left, 0, left + piece.width, piece.height))), np.asarray(piece))
    # a figure with one cell is not cut, unless its legend sits right of it: that goes under it
    one, ax = plt.subplots(figsize=(5.5, 3))
    ax.plot([0, 1], label="a line")
    assert nf.sliced_image(one, nf.tight_drawing(one)) is None
    ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1))
    drawing = nf.tight_drawing(one)
    stack = nf.sliced_image(one, drawing)
    assert stack is not None and stack.width < drawing[0].width and stack.height > drawing[0].height


@pytest.mark.parametrize("sharex", [True, "col"])
def test_a_shared_x_axis_is_labelled_under_the_last_panel_sharing_it(sharex):
    """sharex labels only the bottom row; stacked row by row, an x axis is labelled under the last of
    each run of panels that share it (all six with sharex=True; each panel with "col", whose
    neighbour in the stack is in the other column), never cut from the drawing."""
    fig, axes = plt.subplots(3, 2, figsize=(9, 6.5), sharex=sharex)
    for k, ax in enumerate(axes.flat):
        ax.plot(np.arange(50.0), np.sin(np.arange(50.0) / 5 + k))
        ax.set_ylabel(f"panel {k}")
    for ax in axes[-1]:
        ax.set_xlabel("time t (s)")
    assert nf.sliced_image(fig, nf.tight_drawing(fig)) is None
    copy = nf.narrow_copy(fig)
    stacked = [cell[0] for cell in nf._cells(copy)]
    shown = [ax.xaxis.get_tick_params()["labelbottom"] and ax.xaxis.label.get_visible() for ax in stacked]
    assert shown == ([False] * 5 + [True] if sharex is True else [True] * 6)
    assert all(ax.get_xlabel() == "time t (s)" for ax, s in zip(stacked, shown) if s)
    # room between panels for x labels only where a panel shows them
    gaps = [(upper.get_position().y0 - lower.get_position().y1) * copy.get_size_inches()[1]
            for upper, lower in zip(stacked, stacked[1:])]
    copy.canvas.draw()
    label_room = max((ax.bbox.y0 - ax.get_tightbbox().y0) / copy.dpi for ax in stacked)
    assert all(g < label_room for g in gaps) if sharex is True else all(g > label_room for g in gaps)
    assert [ax.xaxis.get_tick_params()["labelbottom"] for ax in axes.flat] == [False] * 4 + [True] * 2  # shown: unchanged


def test_the_one_drawing_png_is_the_tight_box_savefig_saves():
    fig, _ = three_panels()
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", bbox_inches="tight")
    saved = Image.open(io.BytesIO(buffer.getvalue()))
    ours = nf.tight_image(fig)
    assert abs(ours.width - saved.width) <= 1 and abs(ours.height - saved.height) <= 1


def test_the_display_data_carry_the_copy_only_when_it_is_needed():
    small, ax = plt.subplots(figsize=(4, 3))
    ax.plot([0, 1], [0, 1])
    assert set(nf.figure_bundle(small)) == {"image/png"}
    wide, _ = three_panels()
    bundle = nf.figure_bundle(wide)
    assert set(bundle) == {"image/png", "text/html"}
    sources = re.findall(r'(?:srcset|src)="data:image/png;base64,([^"]+)"', bundle["text/html"])
    assert bundle["text/html"].startswith("<picture") and f'media="{nf.NARROW_MEDIA}"' in bundle["text/html"]
    narrow, usual = (base64.b64decode(s) for s in sources)
    assert usual == base64.b64decode(bundle["image/png"])
    assert nf.png_width(narrow) <= nf.PHONE_COLUMN_PX < nf.png_width(usual)
    with nf.without_narrow_copies():
        assert set(nf.figure_bundle(wide)) == {"image/png"}


def test_install_outside_ipython_does_nothing(monkeypatch):
    import IPython

    # Another test of the session may have started an IPython shell: pretend none is running.
    monkeypatch.setattr(IPython, "get_ipython", lambda: None)
    assert nf.install() is False


def draw_wide(a):
    fig, axes = plt.subplots(1, 2, figsize=(9, 3))
    for ax in axes:
        ax.plot([0, 1], [0, a])
        ax.set_ylabel("error (m)")


def draw_small(a):
    fig, ax = plt.subplots(figsize=(3.5, 2.5))
    ax.plot([0, 1], [0, a])


def test_a_panel_of_wide_figures_carries_their_narrow_copies():
    controls = static_controls({"a": 1}, {"a": "a"}, {"a": "range"}, {"a": (1, 2)})
    wide = render_grid(draw_wide, controls, workers=1)
    assert len(wide.narrow_images) == 2
    assert all(image is not None and nf.png_width(image) <= nf.PHONE_COLUMN_PX for image in wide.narrow_images)
    data = json.loads(re.search(r'<script type="application/json" class="pfcourse-panel-data">(.*?)</script>',
                                panel_html(wide)).group(1))
    assert len(data["narrow"]) == 2 and data["narrowMedia"] == nf.NARROW_MEDIA
    small = render_grid(draw_small, controls, workers=1)
    assert small.narrow_images == (None, None)
    assert '"narrow"' not in panel_html(small)
