"""Figure helpers of pfcourse.plotting draw what they say."""

from __future__ import annotations

from types import SimpleNamespace

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from pfcourse.plotting import posterior_bands  # noqa: E402


def test_posterior_bands_draws_one_panel_per_component():
    times = np.arange(5.0)
    result = SimpleNamespace(mean=np.zeros((5, 3)), cov=np.broadcast_to(np.eye(3), (5, 3, 3)))
    fig = posterior_bands(times, np.ones((5, 3)), result, result, ["a", "b", "c"], "PF", "title")
    panels = [ax for ax in fig.axes if ax.has_data()]
    assert len(panels) == 3
    low, high = panels[0].collections[0].get_paths()[0].get_extents().intervaly
    assert (low, high) == (-3.0, 3.0)  # mean 0 +/- 3 sigma with sigma = 1
    plt.close(fig)
