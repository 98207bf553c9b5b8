"""Figures of the robot-localization chapters (scenario C): map, error bands, particle-cloud animation."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.animation import FuncAnimation

from pfcourse.checks import Array
from pfcourse.style import COLORS
from pfcourse.robot.scenario import RobotSimulation, tracking_errors


def robot_map(
    sim: RobotSimulation,
    estimates: Mapping[str, Array] | None = None,
    ax=None,
    odometry: bool = True,
    legend: bool = True,
):
    """Landmarks, true path, odometry path and estimated paths ``{label: (K, 3) means}`` on the map (and a legend)."""
    if ax is None:
        _, ax = plt.subplots(figsize=(5.5, 5.5))
    w = sim.scenario.half_width
    ax.plot(sim.landmarks[:, 0], sim.landmarks[:, 1], "*", color="k", ms=12, label="landmarks")
    for j, (lx, ly) in enumerate(sim.landmarks):
        ax.annotate(f"L{j}", (lx, ly), xytext=(5, 4), textcoords="offset points")
    ax.plot(sim.truth[:, 0], sim.truth[:, 1], "-", color=COLORS["truth"], lw=2, label="true path")
    if odometry:
        ax.plot(sim.odometry_path[:, 0], sim.odometry_path[:, 1], "--", color=COLORS["robot"], lw=1.2, label="odometry")
    palette = [COLORS["estimate"], COLORS["kalman"], COLORS["particles"], "tab:purple"]
    for (label, mean), color in zip((estimates or {}).items(), palette):
        ax.plot(mean[:, 0], mean[:, 1], "-", color=color, lw=1, label=label)
    ax.plot(*sim.truth[0, :2], "o", color=COLORS["truth"])
    ax.set_xlim(-w, w)
    ax.set_ylim(-w, w)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    if legend:
        ax.legend(loc="upper left")
    return ax


def error_bands(sim: RobotSimulation, mean: Array, cov: Array, axes: Sequence | None = None, label: str = "estimate"):
    """Error ``estimate - truth`` per coordinate with the filter's own ``+/- 3 sigma`` band (heading in degrees)."""
    if axes is None:
        _, axes = plt.subplots(3, 1, figsize=(7.0, 6.0), sharex=True)
    t = np.arange(sim.scenario.n_steps) * sim.scenario.dt
    err = tracking_errors(sim.truth, mean)
    sigma = np.sqrt(np.diagonal(cov, axis1=1, axis2=2))
    scale = (1.0, 1.0, 180.0 / np.pi)
    names = ("x error (m)", "y error (m)", "heading error (deg)")
    for i, ax in enumerate(axes):
        ax.fill_between(t, -3 * sigma[:, i] * scale[i], 3 * sigma[:, i] * scale[i], color=COLORS["estimate"], alpha=0.2, lw=0, label="±3σ of the filter")
        ax.plot(t, err[:, i] * scale[i], color=COLORS["estimate"], lw=0.8, label=label)
        ax.axhline(0.0, color="k", lw=0.5)
        ax.set_ylabel(names[i])
    axes[-1].set_xlabel("time (s)")
    axes[0].legend(loc="upper right", ncols=2)
    return axes


def animate_cloud(
    sim: RobotSimulation,
    particles: Array,
    weights: Array,
    means: Array,
    frames: Sequence[int],
    window: float | None = 3.0,
    max_points: int = 3000,
    interval: int = 250,
) -> FuncAnimation:
    """Animate the weighted particle cloud at the steps ``frames``.

    ``particles`` ``(K, N, 3)`` and ``weights`` ``(K, N)`` as stored by
    ``ParticleFilter.run(..., store_particles=True)``; ``means`` ``(K, 3)``.  With
    ``window`` the view follows the true robot (+/- ``window`` metres); with
    ``None`` it shows the whole map.  Marker area is proportional to the weight;
    at most ``max_points`` particles are drawn per frame (the first ones, which
    are as random as any).  Render with ``anim.to_jshtml()``.
    """
    fig, ax = plt.subplots(figsize=(5.0, 5.0), dpi=72)
    n = min(particles.shape[1], max_points)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.plot(sim.landmarks[:, 0], sim.landmarks[:, 1], "*", color="k", ms=12)
    (path,) = ax.plot([], [], "-", color=COLORS["truth"], lw=1.5, label="true path")
    cloud = ax.scatter(particles[frames[0], :n, 0], particles[frames[0], :n, 1], s=4, color=COLORS["particles"], alpha=0.6, label="particles")
    (truth,) = ax.plot([], [], "o", color=COLORS["truth"], ms=7)
    (est,) = ax.plot([], [], "x", color=COLORS["estimate"], ms=9, mew=2, label="PF mean")
    (sight,) = ax.plot([], [], ":", color="tab:green", lw=1.5, label="observed landmark")
    title = ax.set_title("")
    ax.legend(loc="lower left", fontsize=8)
    w = sim.scenario.half_width
    j = sim.landmark_index

    def draw(i: int):
        k = frames[i]
        x = particles[k, :n]
        wk = weights[k, :n] * particles.shape[1]
        cloud.set_offsets(x[:, :2])
        cloud.set_sizes(np.clip(6.0 * wk, 0.5, 60.0))
        path.set_data(sim.truth[: k + 1, 0], sim.truth[: k + 1, 1])
        truth.set_data([sim.truth[k, 0]], [sim.truth[k, 1]])
        est.set_data([means[k, 0]], [means[k, 1]])
        if j[k] >= 0:
            sight.set_data([sim.truth[k, 0], sim.landmarks[j[k], 0]], [sim.truth[k, 1], sim.landmarks[j[k], 1]])
        else:
            sight.set_data([], [])
        if window is None:
            ax.set_xlim(-w, w)
            ax.set_ylim(-w, w)
        else:
            ax.set_xlim(sim.truth[k, 0] - window, sim.truth[k, 0] + window)
            ax.set_ylim(sim.truth[k, 1] - window, sim.truth[k, 1] + window)
        title.set_text(f"t = {k * sim.scenario.dt:.0f} s")
        return [cloud, path, truth, est, sight, title]

    anim = FuncAnimation(fig, draw, frames=len(frames), interval=interval, blit=False)
    plt.close(fig)
    return anim
