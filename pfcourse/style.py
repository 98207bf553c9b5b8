"""Figures of the book, in one consistent style.

Call :func:`use_style` once at the top of a notebook.  The functions here draw
onto axes they are given (or create), label their axes with units, and return
the artists, so a notebook can still adjust them.
"""

from __future__ import annotations

import matplotlib as mpl
import matplotlib.pyplot as plt
import numpy as np
from matplotlib import ticker
from matplotlib.animation import FuncAnimation
from matplotlib.patches import Ellipse, Polygon

from .diagnostics import confidence_ellipse
from .landmarks import LandmarkScenario, LandmarkSimulation

#: Colours used for the same thing in every figure.
COLORS = {
    "truth": "black",
    "robot": "tab:blue",
    "estimate": "tab:red",
    "kalman": "tab:green",
    "particles": "tab:orange",
    "seen": "tab:green",
    "unseen": "tab:gray",
    "fov": "tab:cyan",
}

STYLE = {
    "figure.figsize": (7.0, 4.2),
    "figure.dpi": 100,
    "savefig.dpi": 100,
    "axes.grid": True,
    "grid.alpha": 0.3,
    "axes.spines.top": False,
    "axes.spines.right": False,
    "axes.titlesize": 11,
    "axes.labelsize": 10,
    "legend.fontsize": 9,
    "legend.frameon": False,
    "animation.embed_limit": 40.0,
}


def use_style() -> None:
    """Apply the book's matplotlib style (sizes, grid, fonts) to every later figure."""
    mpl.rcParams.update(STYLE)



def plain_log_axis(ax, which: str = "y", subs: tuple[float, ...] = (1.0, 3.0)) -> None:
    """Put ``which`` (``"x"``, ``"y"`` or ``"xy"``) of ``ax`` on a log scale that is cheap to redraw.

    Major ticks at ``subs`` times the powers of ten (``(1, 3)`` gives 0.1, 0.3, 1, 3, ...;
    ``(1, 2, 5)`` gives 0.1, 0.2, 0.5, 1, ...), labelled as plain numbers (``%g``), and no minor
    ticks.  With two or more ``subs``, a view holding fewer than two of these ticks falls back
    to linear-style ticks (matplotlib's ``LogLocator``), so it is never left unlabelled.
    Matplotlib's default log axis
    typesets every label as mathtext (``10^{-1}``) and adds eight minor ticks per decade; on a
    widget panel those two cost about a third of a redraw, and they add no information that the
    gridlines at the labelled ticks do not give.
    """
    for name in which:
        getattr(ax, f"set_{name}scale")("log")
        axis = getattr(ax, f"{name}axis")
        axis.set_major_locator(ticker.LogLocator(subs=subs))
        axis.set_major_formatter(ticker.FormatStrFormatter("%g"))
        axis.set_minor_locator(ticker.NullLocator())


def ellipse_patch(mean, cov, probability: float = 0.95, **kwargs) -> Ellipse:
    """A matplotlib :class:`~matplotlib.patches.Ellipse` for a 2-D Gaussian's confidence region."""
    centre, width, height, angle = confidence_ellipse(mean, cov, probability)
    kwargs.setdefault("fill", False)
    return Ellipse(centre, width, height, angle=angle, **kwargs)


def landmark_scene(
    scenario: LandmarkScenario, sim: LandmarkSimulation, ax=None, limits=None
):
    """Draw scenario A's world: robot path, landmarks (green if ever seen), field of view at the end."""
    if ax is None:
        _, ax = plt.subplots(figsize=(5.5, 5.5))
    X = sim.X
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
    robot = sim.X[:, :2]
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
            lx, ly = sim.X[k, 2 + 2 * j : 4 + 2 * j]
            seen = bool(sim.seen[k, j])
            squares[j].set_data([lx], [ly])
            squares[j].set_color(COLORS["seen" if seen else "unseen"])
            squares[j].set_markeredgecolor("k")
            if seen:
                dz = sim.Z[k, 2 * j : 2 * j + 2]
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
    axes.flat[0].legend(fontsize=8, loc="upper right")
    fig.suptitle(title)
    return fig
