"""Animations of weighted particle clouds against the exact Gaussian posterior (scenario A).

Each frame is one time step ``k``.  For every 2-D block of the state (the robot
and each landmark) a panel shows the particles ``x_k^i`` (marker area
proportional to ``N W_k^i``), the particle filter's 95 % ellipse
``(x - mu_k)^T Sigma_k^{-1} (x - mu_k) = chi2_{0.95}(2)`` from the weighted
mean and covariance, the exact (Kalman) 95 % ellipse and the true position.
Render with ``HTML(anim.to_jshtml())``.
"""

from __future__ import annotations

from collections.abc import Sequence

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.animation import FuncAnimation

from pfcourse.errors import ParameterError
from pfcourse.filter import FilterResult
from pfcourse.landmarks.kalman import KalmanResult
from pfcourse.style import COLORS, ellipse_patch


def animate_clouds(
    results: dict[str, FilterResult],
    kalman: KalmanResult,
    truth: np.ndarray,
    frames: Sequence[int],
    limits: tuple[float, float] = (-3.0, 6.0),
    interval: int = 400,
) -> FuncAnimation:
    """One panel per filter in ``results`` (each run with ``store_particles=True``), side by side."""
    for name, res in results.items():
        if res.particles is None:
            raise ParameterError(f"{name}: run the filter with store_particles=True to animate its cloud")
    n_blocks = truth.shape[1] // 2
    fig, axes = plt.subplots(1, len(results), figsize=(4.2 * len(results), 4.4), dpi=72, squeeze=False)
    axes = axes[0]
    heads = []
    for ax in axes:
        ax.set_xlim(*limits)
        ax.set_ylim(*limits)
        ax.set_aspect("equal")
        ax.set_xlabel("x (m)")
        heads.append(ax.set_title(""))
    axes[0].set_ylabel("y (m)")
    artists: list = []

    def draw(k: int):
        for a in artists:
            a.remove()
        artists.clear()
        for ax, head, (name, res) in zip(axes, heads, results.items()):
            size = 4 * np.clip(res.weights[k] * res.n_particles, 0.05, 40)
            for j in range(n_blocks):
                blk = slice(2 * j, 2 * j + 2)
                artists.append(ax.scatter(res.particles[k, :, 2 * j], res.particles[k, :, 2 * j + 1],
                                          s=size, color=COLORS["particles"], alpha=0.5))
                artists.append(ax.add_patch(ellipse_patch(kalman.mean[k, blk], kalman.cov[k, blk, blk],
                                                          color=COLORS["kalman"], lw=2)))
                artists.append(ax.add_patch(ellipse_patch(res.mean[k, blk], res.cov[k, blk, blk],
                                                          color=COLORS["estimate"], lw=1.5)))
                artists.append(ax.plot(*truth[k, blk], "+", color=COLORS["truth"], ms=10)[0])
            head.set_text(f"{name}: k = {k}, ESS = {res.ess[k]:.1f}")
        return artists

    anim = FuncAnimation(fig, draw, frames=list(frames), interval=interval, blit=False)
    plt.close(fig)
    return anim
