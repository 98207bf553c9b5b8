"""overlapping_texts finds labels drawn over each other, and nothing in a clean figure."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pytest  # noqa: E402

from pfcourse.book.legibility import overlapping_texts  # noqa: E402


def test_two_annotations_on_the_same_spot_are_found():
    fig, ax = plt.subplots(figsize=(4, 3))
    ax.plot([1, 2], [1, 2], "o")
    ax.annotate("PF N=300", (1.5, 1.5))
    ax.annotate("EKF", (1.52, 1.5))
    assert ("PF N=300", "EKF") in overlapping_texts(fig)
    plt.close(fig)


def test_a_plain_figure_with_legend_beside_the_axes_has_none():
    fig, ax = plt.subplots(figsize=(5, 3), layout="constrained")
    for k in range(3):
        ax.errorbar([k + 1.0], [k + 1.0], yerr=0.1, fmt="os^"[k], label=f"filter {k}")
    ax.set_xscale("log")
    ax.set_xlabel("run time per step (ms)")
    ax.set_ylabel("RMSE (m)")
    ax.set_title("accuracy against cost")
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0))
    assert overlapping_texts(fig) == []
    plt.close(fig)


def test_a_crowded_axis_is_found():
    fig, ax = plt.subplots(figsize=(1.5, 1.5))
    ax.set_xticks(range(10), [f"label {k}" for k in range(10)])
    assert overlapping_texts(fig)
    plt.close(fig)


def test_tick_labels_outside_the_view_are_not_counted():
    """Matplotlib keeps labels for ticks beyond the limits (0.01 and 0.02 here, left of a view that
    starts at 0.05), placed off the axes where they can meet other labels; they are not drawn."""
    from matplotlib import ticker

    from pfcourse.book.legibility import _drawn_texts

    fig, ax = plt.subplots(figsize=(6, 4), layout="constrained")
    ax.errorbar([0.06, 0.1, 0.45], [0.26, 0.19, 0.19], yerr=0.05, fmt="o")
    ax.set_xscale("log")
    ax.set_xlim(0.05, 0.5)
    ax.xaxis.set_major_locator(ticker.LogLocator(subs=(1.0, 2.0, 5.0)))
    ax.xaxis.set_major_formatter(ticker.FormatStrFormatter("%g"))
    ax.xaxis.set_minor_locator(ticker.NullLocator())  # as pfcourse.book.style.plain_log_axis: else the
    fig.canvas.draw()                                 # minor label 6x10^-2 meets 0.05 (counted)
    kept = [t.get_text() for t in ax.get_xticklabels()]
    drawn = [t.get_text() for t in _drawn_texts(fig)]
    assert "0.01" in kept and "0.02" in kept
    assert "0.01" not in drawn and "0.02" not in drawn and "0.1" in drawn and "0.5" in drawn
    assert overlapping_texts(fig) == []
    plt.close(fig)


def test_a_suptitle_is_not_its_own_clash():
    fig, axes = plt.subplots(1, 2, figsize=(6, 3), layout="constrained")
    fig.suptitle("two panels")
    axes[0].set_title("left")
    axes[1].set_title("right")
    assert overlapping_texts(fig) == []
    plt.close(fig)


def test_smallest_text_is_measured_at_column_width():
    import matplotlib.pyplot as plt

    from pfcourse.book.legibility import COLUMN_PX, smallest_text_px

    fig, ax = plt.subplots(figsize=(10, 4), dpi=100)
    ax.plot([0, 1], [0, 1], label="a curve")
    ax.legend(fontsize=6)
    size, text = smallest_text_px(fig)
    assert text == "a curve"
    width = fig.get_tightbbox(fig.canvas.get_renderer()).width * 100
    assert width > COLUMN_PX and size == pytest.approx(6 * 100 / 72 * COLUMN_PX / width)  # scaled down to the column
    assert size < 8
    plt.close(fig)
    fig, ax = plt.subplots(figsize=(5, 3), dpi=100)  # narrower than the column: shown at its natural size
    ax.set_xlabel("metres", fontsize=9)
    ax.set_xticks([])
    ax.set_yticks([])
    assert smallest_text_px(fig)[0] == pytest.approx(9 * 100 / 72)
    plt.close(fig)


def _log_axis_figure(width_in: float, minor_labels: bool = True):
    """A log x axis over less than two decades (20 to 900), on which matplotlib labels the minor ticks
    (2x10^1, 3x10^1, ...), unless ``minor_labels`` is False."""
    from matplotlib import ticker

    fig, ax = plt.subplots(figsize=(width_in, 2.5), layout="constrained")
    ax.plot([20, 900], [1, 2])
    ax.set_xscale("log")
    ax.set_xlim(20, 900)
    ax.set_xlabel("particles N")
    if not minor_labels:
        ax.xaxis.set_minor_formatter(ticker.NullFormatter())
    return fig, ax


def test_overlapping_minor_tick_labels_of_a_log_axis_are_found():
    """Matplotlib's labels of a log axis's minor ticks ("2x10^1", "3x10^1", ...) crowd a narrow
    axis; they are drawn as the major ones are, so the check counts them."""
    fig, ax = _log_axis_figure(3.0)
    fig.canvas.draw()
    minor = [t.get_text() for t in ax.get_xticklabels(minor=True) if t.get_text()]
    assert len(minor) >= 4  # the labels this test is about are there
    pairs = overlapping_texts(fig)
    assert any(a in minor and b in minor for a, b in pairs), pairs
    plt.close(fig)


def test_the_same_log_axis_with_its_minor_labels_off_or_room_enough_has_none():
    fig, _ = _log_axis_figure(3.0, minor_labels=False)
    assert overlapping_texts(fig) == []
    plt.close(fig)
    fig, _ = _log_axis_figure(12.0)  # wide enough for every minor label
    assert overlapping_texts(fig) == []
    plt.close(fig)


def test_tick_labels_on_the_top_axis_meeting_the_title_are_found():
    """label2 (a secondary side's tick labels) is counted: here the top tick labels meet the title,
    drawn into the axes' top edge."""
    fig, ax = plt.subplots(figsize=(4, 3))
    ax.tick_params(labeltop=True)
    ax.set_title("the title", y=1.0, pad=0)
    labels = [t.get_text() for t in ax.get_xticklabels()]
    pairs = overlapping_texts(fig)
    assert any("the title" in pair and (set(pair) & set(labels)) for pair in pairs), pairs
    plt.close(fig)


def test_an_illegible_figure_warns_and_a_clean_one_does_not():
    import warnings

    from pfcourse.book.legibility import LegibilityWarning, warn_if_illegible

    fig, ax = plt.subplots(figsize=(4, 3), dpi=100)
    ax.annotate("PF N=300", (0.5, 0.5))
    ax.annotate("EKF", (0.52, 0.5))
    with pytest.warns(LegibilityWarning, match="drawn over each other"):
        warn_if_illegible(fig)
    plt.close(fig)
    fig, ax = plt.subplots(figsize=(10, 4), dpi=100)
    ax.plot([0, 1], [0, 1], label="a curve")
    ax.legend(fontsize=6)
    with pytest.warns(LegibilityWarning, match="'a curve' shows at"):
        warn_if_illegible(fig)
    plt.close(fig)
    fig, ax = plt.subplots(figsize=(5, 3), dpi=100)
    ax.set_xlabel("metres")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        warn_if_illegible(fig)
    plt.close(fig)


def test_a_figure_shown_by_the_books_formatter_is_checked(monkeypatch):
    """Under the tests' check, the book's figure formatter (pfcourse.book.narrow_figures, which draws the
    figure itself, not through print_figure) checks every figure it shows, its narrow copy included."""
    from IPython.core import pylabtools

    from pfcourse.book import narrow_figures

    checked = []

    def print_figure(figure, *args, **kwargs):
        raise AssertionError("the book's formatter draws the figure itself")

    print_figure._checks_legibility = checked.append
    monkeypatch.setattr(pylabtools, "print_figure", print_figure)
    monkeypatch.setitem(plt.rcParams, "savefig.dpi", 100)  # the book's style
    fig, ax = plt.subplots(figsize=(9, 3), dpi=100)  # one wide axes: a narrow copy laid out anew
    ax.plot([0, 1], [0, 1])
    ax.set_title("a wide figure")
    bundle = narrow_figures.figure_bundle(fig)
    assert "text/html" in bundle and checked[0] is fig and len(checked) == 2  # the figure, then its copy
    plt.close(fig)


@pytest.mark.parametrize("workers", [1, 2])
def test_a_panel_figure_is_checked_too(monkeypatch, workers):
    """Under the tests' check, each figure a static panel renders (in forked workers too) is checked,
    and what is found is warned in the notebook's process with the grid point."""
    from IPython.core import pylabtools

    from pfcourse.book.legibility import LegibilityWarning, warn_if_illegible
    from pfcourse.book.static_panel import StaticControl, render_grid

    def print_figure(figure, *args, **kwargs):
        return b""

    print_figure._checks_legibility = warn_if_illegible
    monkeypatch.setattr(pylabtools, "print_figure", print_figure)

    def draw(shift):
        fig, ax = plt.subplots(figsize=(4, 3), dpi=100)
        ax.annotate("PF N=300", (0.5, 0.5))
        ax.annotate("EKF", (0.5 + shift, 0.5))

    controls = [StaticControl("shift", "shift", (0.02, 0.4), 0, "range", True)]
    with pytest.warns(LegibilityWarning, match=r"at \{'shift': 0.02\}: texts drawn over each other") as caught:
        render_grid(draw, controls, workers=workers)
    assert not [w for w in caught if "0.4" in str(w.message)]
