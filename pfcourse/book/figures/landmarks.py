"""Figures of scenario A: the world seen from above, and an animation of one run."""

from __future__ import annotations

import matplotlib.pyplot as plt
from matplotlib.animation import FuncAnimation
from matplotlib.patches import Polygon

from pfcourse.scenarios.landmarks.scenario import LandmarkScenario, LandmarkSimulation
from pfcourse.book.style import COLORS


def landmark_scene(
    scenario: LandmarkScenario, sim: LandmarkSimulation, ax=None, limits=None
):
    """Draw scenario A's world: robot path, landmarks (green if ever seen), field of view at the end."""
    if ax is None:
        _, ax = plt.subplots(figsize=(5.5, 5.5))
    X = sim.truth
    robot = X[:, :2]
    landmarks = X[-1, 2:].reshape(-1, 2)
    ax.plot(robot[:, 0], robot[:, 1], "-", color=COLORS["robot"], lw=1, label="robot path")
    ax.plot(*robot[0], "o", color=COLORS["robot"], label="start")
    ever_seen = sim.seen.any(axis=0)
    for j, (lx, ly) in enumerate(landmarks):
        ax.plot(lx, ly, "s", ms=9, mec="k", color=COLORS["seen" if ever_seen[j] else "unseen"])
        ax.annotate(f"L{j + 1}", (lx, ly), xytext=(6, 4), textcoords="offset points")
    ax.add_patch(
        Polygon(scenario.fov_polygon(robot[-1], extent=_extent(limits)), closed=True,
                color=COLORS["fov"], alpha=0.2, label="field of view (last step)")
    )
    _world_axes(ax, limits)
    return ax


def animate_landmarks(
    scenario: LandmarkScenario,
    sim: LandmarkSimulation,
    limits: tuple[float, float] | None = None,
    interval: int = 300,
) -> FuncAnimation:
    """Animation of one run of scenario A: robot, trail, field of view and measured offsets.

    Each frame is one time step.  Landmarks in view are green and joined to the
    robot by the measured offset ``z^j = l^j - r + v^j`` (drawn from the robot);
    the others are grey.  Render with ``anim.to_jshtml()``.
    """
    fig, ax = plt.subplots(figsize=(5.0, 5.0), dpi=72)
    _world_axes(ax, limits)
    extent = _extent(limits)
    robot = sim.truth[:, :2]
    n_lm = scenario.n_landmarks
    fov = Polygon(scenario.fov_polygon(robot[0], extent), closed=True, color=COLORS["fov"], alpha=0.2)
    ax.add_patch(fov)
    (trail,) = ax.plot([], [], "--", color=COLORS["robot"], lw=1)
    (dot,) = ax.plot([], [], "o", color=COLORS["robot"], ms=8)
    squares = [ax.plot([], [], "s", ms=9, mec="k")[0] for _ in range(n_lm)]
    arrows = [ax.plot([], [], "-", color=COLORS["seen"], lw=2)[0] for _ in range(n_lm)]
    title = ax.set_title("")

    def draw(k: int):
        fov.set_xy(scenario.fov_polygon(robot[k], extent))
        start = max(k - 15, 0)
        trail.set_data(robot[start : k + 1, 0], robot[start : k + 1, 1])
        dot.set_data([robot[k, 0]], [robot[k, 1]])
        for j in range(n_lm):
            lx, ly = sim.truth[k, 2 + 2 * j : 4 + 2 * j]
            seen = bool(sim.seen[k, j])
            squares[j].set_data([lx], [ly])
            squares[j].set_color(COLORS["seen" if seen else "unseen"])
            squares[j].set_markeredgecolor("k")
            if seen:
                dz = sim.measurements[k, 2 * j : 2 * j + 2]
                arrows[j].set_data([robot[k, 0], robot[k, 0] + dz[0]], [robot[k, 1], robot[k, 1] + dz[1]])
            else:
                arrows[j].set_data([], [])
        title.set_text(f"t = {sim.T[k]:.0f} s: {int(sim.seen[k].sum())} landmark(s) in view")
        return [fov, trail, dot, title, *squares, *arrows]

    anim = FuncAnimation(fig, draw, frames=len(sim.T), interval=interval, blit=False)
    plt.close(fig)
    return anim


def _extent(limits) -> float:
    return 6.0 if limits is None else float(limits[1])


def _world_axes(ax, limits) -> None:
    lo, hi = (-6.0, 6.0) if limits is None else limits
    ax.set_xlim(lo, hi)
    ax.set_ylim(lo, hi)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
