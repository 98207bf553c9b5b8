"""Figures of the robot-localization chapters (scenario C): map, error bands, the cloud animation's hooks."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import matplotlib.pyplot as plt
import numpy as np

from pfcourse.checks import Array
from pfcourse.book.style import COLORS
from pfcourse.scenarios.robot.scenario import RobotSimulation, tracking_errors


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


def landmarks_background(sim: RobotSimulation):
    """A ``background(ax)`` hook for :func:`pfcourse.book.figures.clouds.animate_clouds`: the landmarks."""

    def draw(ax) -> None:
        ax.plot(sim.landmarks[:, 0], sim.landmarks[:, 1], "*", color="k", ms=12, label="landmarks")

    return draw


def sight_overlay(sim: RobotSimulation):
    """An ``overlay(ax, k)`` hook for :func:`pfcourse.book.figures.clouds.animate_clouds`: the line from
    the true robot to the landmark it observes at step ``k`` (nothing without a measurement)."""
    j = sim.landmark_index

    def draw(ax, k: int) -> list:
        if j[k] < 0:
            return []
        x, y = sim.truth[k, 0], sim.truth[k, 1]
        lx, ly = sim.landmarks[j[k]]
        return [ax.plot([x, lx], [y, ly], ":", color="tab:green", lw=1.5, label="observed landmark")[0]]

    return draw
