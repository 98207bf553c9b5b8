"""Figure helpers of pfcourse.book.style draw what they say."""

from __future__ import annotations

from types import SimpleNamespace

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from pfcourse.book.figures.bands import posterior_bands  # noqa: E402


def test_posterior_bands_draws_one_panel_per_component():
    times = np.arange(5.0)
    result = SimpleNamespace(mean=np.zeros((5, 3)), cov=np.broadcast_to(np.eye(3), (5, 3, 3)))
    fig = posterior_bands(times, np.ones((5, 3)), result, result, ["a", "b", "c"], "PF", "title")
    panels = [ax for ax in fig.axes if ax.has_data()]
    assert len(panels) == 3
    low, high = panels[0].collections[0].get_paths()[0].get_extents().intervaly
    assert (low, high) == (-3.0, 3.0)  # mean 0 +/- 3 sigma with sigma = 1
    plt.close(fig)


def test_plain_log_axis_labels_plain_numbers_without_minor_ticks():
    from pfcourse.book.style import plain_log_axis

    fig, ax = plt.subplots()
    ax.plot([1, 2], [0.02, 40.0])
    plain_log_axis(ax, "y")
    fig.canvas.draw()
    assert ax.get_yscale() == "log"
    assert len(ax.yaxis.get_minorticklocs()) == 0
    labels = {t.get_text() for t in ax.get_yticklabels() if ax.get_ylim()[0] <= t.get_position()[1] <= ax.get_ylim()[1]}
    assert {"0.03", "0.1", "0.3", "1", "3", "10", "30"} <= labels  # 1 and 3 times powers of ten, no mathtext
    ax.set_ylim(1.2, 2.5)  # no 1x or 3x power of ten inside: the locator falls back to linear ticks
    assert sum(1.2 <= v <= 2.5 for v in ax.yaxis.get_majorticklocs()) >= 2
    plt.close(fig)
