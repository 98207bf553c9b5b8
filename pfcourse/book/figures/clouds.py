"""The animated particle cloud of every chapter: one function for every scenario.

Each frame is one time step ``k``.  One panel per filter run shows, for every 2-D block of
the state (the robot's position, each landmark), the particles ``x_k^i`` (marker area
proportional to ``N W_k^i``, or ``max_points`` particles drawn by weight), the true state,
and either the filter's 95 % ellipse ``(x - mu_k)^T Sigma_k^{-1} (x - mu_k) = chi2_{0.95}(2)``
(with the exact Kalman ellipse when a reference is given) or the filter's mean.  Scenario
details come in through two hooks: ``background(ax)`` draws what does not move (a map,
landmarks) and ``overlay(ax, k)`` what belongs to step ``k`` (the landmark observed).
Render with ``HTML(anim.to_jshtml())``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.animation import FuncAnimation

from pfcourse.checks import Array
from pfcourse.errors import ParameterError
from pfcourse.results import FilterResult
from pfcourse.results import KalmanResult
from pfcourse.book.style import COLORS, ellipse_patch


def animate_clouds(
    results: dict[str, FilterResult],
    kalman: KalmanResult | None,
    truth: Array,
    frames: Sequence[int],
    limits: tuple[float, float] | None = (-3.0, 6.0),
    interval: int = 400,
    *,
    blocks: Sequence[tuple[int, int]] | None = None,
    ellipses: bool = True,
    follow: float | None = None,
    scale: float = 1.0,
    unit: str = "m",
    max_points: int | None = None,
    by_weight: bool = False,
    trail: bool = False,
    background: Callable | None = None,
    overlay: Callable | None = None,
    title: Callable[[str, int, FilterResult], str] | None = None,
    legend: bool = False,
) -> FuncAnimation:
    """Animate the clouds of ``results`` (each run with ``collect=[Clouds()]``), one panel each.

    ``truth`` ``(K, d)``; ``blocks`` the pairs of state indices drawn as clouds (default
    ``(0, 1), (2, 3), ...``); ``kalman`` an exact reference whose ellipses are drawn too
    (``None``: none).  ``ellipses=False`` marks the filter's mean instead of its ellipse.
    The view is ``limits`` (in plotted units) or, with ``follow``, a window of +/- ``follow``
    around the first block of the truth.  Coordinates are multiplied by ``scale`` (e.g.
    1/1000 for km, with ``unit="km"``).  ``max_points`` caps the particles drawn per frame:
    the first ones (marker area by weight), or with ``by_weight=True`` a draw by weight
    (seeded, equal markers).  ``trail`` draws the true and estimated paths up to ``k``.
    ``title(name, k, result)`` gives each panel's title (default: step and ESS).
    """
    for name, res in results.items():
        if res.particles is None:
            raise ParameterError(f"{name}: run the filter with collect=[Clouds()] to animate its cloud")
    truth = np.asarray(truth, dtype=float)
    if blocks is None:
        blocks = [(2 * j, 2 * j + 1) for j in range(truth.shape[1] // 2)]
    frames = list(frames)
    fig, axes = plt.subplots(1, len(results), figsize=(min(4.2 * len(results), 7.0) if len(results) > 1 else 5.0,
                                                       4.4 if len(results) > 1 else 5.0),
                             dpi=72, squeeze=False)
    axes = axes[0]
    heads = []
    for ax in axes:
        if background is not None:
            background(ax)
        if limits is not None:
            ax.set_xlim(*limits)
            ax.set_ylim(*limits)
        ax.set_aspect("equal")
        ax.set_xlabel(f"x ({unit})")
        heads.append(ax.set_title(""))
    axes[0].set_ylabel(f"y ({unit})")
    pick = np.random.default_rng(0)
    artists: list = []
    default_title = (lambda name, k, res: f"{name}: k = {k}, ESS = {res.ess[k]:.1f}")
    title = title or default_title

    def draw(k: int):
        for a in artists:
            a.remove()
        artists.clear()
        for ax, head, (name, res) in zip(axes, heads, results.items()):
            n = res.particles.shape[1]
            if by_weight and max_points is not None:
                idx = pick.choice(n, max_points, p=res.weights[k])
                size = np.full(max_points, 4.0)
            else:
                idx = np.arange(min(n, max_points or n))
                size = 4 * np.clip(res.weights[k, idx] * n, 0.05, 40)
            for i, j in blocks:
                blk = [i, j]
                artists.append(ax.scatter(res.particles[k, idx, i] * scale, res.particles[k, idx, j] * scale,
                                          s=size, color=COLORS["particles"], alpha=0.5,
                                          label="particles" if (i, j) == tuple(blocks[0]) else None))
                if ellipses:
                    if kalman is not None:
                        artists.append(ax.add_patch(ellipse_patch(kalman.mean[k, blk] * scale,
                                                                  kalman.cov[k][np.ix_(blk, blk)] * scale**2,
                                                                  color=COLORS["kalman"], lw=2)))
                    artists.append(ax.add_patch(ellipse_patch(res.mean[k, blk] * scale,
                                                              res.cov[k][np.ix_(blk, blk)] * scale**2,
                                                              color=COLORS["estimate"], lw=1.5)))
                else:
                    artists.append(ax.plot(res.mean[k, i] * scale, res.mean[k, j] * scale, "x",
                                           color=COLORS["estimate"], ms=9, mew=2, label="estimate")[0])
                artists.append(ax.plot(truth[k, i] * scale, truth[k, j] * scale, "+",
                                       color=COLORS["truth"], ms=10, label="truth")[0])
            if trail:
                i, j = blocks[0]
                artists.append(ax.plot(truth[: k + 1, i] * scale, truth[: k + 1, j] * scale, "-",
                                       color=COLORS["truth"], lw=1.5)[0])
                artists.append(ax.plot(res.mean[: k + 1, i] * scale, res.mean[: k + 1, j] * scale, "-",
                                       color=COLORS["estimate"], lw=1.2)[0])
            if overlay is not None:
                artists.extend(overlay(ax, k))
            if follow is not None:
                i, j = blocks[0]
                ax.set_xlim(truth[k, i] * scale - follow, truth[k, i] * scale + follow)
                ax.set_ylim(truth[k, j] * scale - follow, truth[k, j] * scale + follow)
            head.set_text(title(name, k, res))
        if legend:  # under the axes, off the cloud
            handles, labels = axes[0].get_legend_handles_labels()
            artists.append(fig.legend(handles, labels, loc="lower center", ncols=min(len(labels), 4)))
        return artists

    # Frames are saved without a tight box: lay the figure out once, on the first frame, with
    # room for the y label, the titles and (when there is one) the legend under the axes.
    draw(frames[0])
    fig.tight_layout(pad=0.6, rect=(0.0, 0.07 if legend else 0.0, 1.0, 1.0))
    anim = FuncAnimation(fig, draw, frames=frames, interval=interval, blit=False)
    plt.close(fig)
    return anim
