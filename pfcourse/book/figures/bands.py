"""Posterior bands: a particle filter's +/-3 sigma band against the exact (Kalman) band, per state component."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np

from pfcourse.book.style import COLORS


def posterior_bands(times, truth, kalman, estimate, labels, estimate_name: str, title: str):
    """One panel per state component: the exact and the particle +/-3 sigma bands, means, truth.

    ``kalman`` and ``estimate`` have ``mean`` ``(K, d)`` and ``cov`` ``(K, d, d)``; the
    bands are ``m_k +/- 3 sqrt(P_k[j, j])``.  Returns the figure.
    """
    rows = (len(labels) + 1) // 2
    fig, axes = plt.subplots(rows, 2, figsize=(9, 2.2 * rows), sharex=True)
    for j, ax in enumerate(axes.flat[: len(labels)]):
        for result, name, color, alpha in ((kalman, "Kalman", COLORS["kalman"], 0.2),
                                           (estimate, estimate_name, COLORS["estimate"], 0.3)):
            sd = np.sqrt(result.cov[:, j, j])
            ax.fill_between(times, result.mean[:, j] - 3 * sd, result.mean[:, j] + 3 * sd,
                            color=color, alpha=alpha, label=rf"{name} $\pm3\sigma$")
            ax.plot(times, result.mean[:, j], color=color, lw=1)
        ax.plot(times, truth[:, j], color=COLORS["truth"], lw=0.8, ls="--")
        ax.set_ylabel(f"{labels[j]} (m)")
    for ax in axes[-1]:
        ax.set_xlabel("time t (s)")
    axes.flat[0].legend(loc="upper right")
    fig.suptitle(title)
    return fig
