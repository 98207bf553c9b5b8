"""Figures of the terrain chapters (17-19): the map in kilometres, and one flight's filter at a glance.

:func:`draw_map` draws the elevation model (filled contours, or a shaded relief) with axes in km;
:func:`flight_figure` draws one run of a filter on one flight, the cloud over the map beside the
horizontal error over time, the figure the terrain panels redraw for each setting.
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np

from pfcourse.book.style import COLORS, plain_log_axis
from pfcourse.metrics import position_error
from pfcourse.scenarios.terrain.map import TerrainMap, hillshade
from pfcourse.studies.terrain import DIVERGED_ERROR

KM = 1000.0

#: The colour scale of heights (m), the same in every terrain figure.
HEIGHT_RANGE = (150.0, 1150.0)


def draw_map(ax, terrain: TerrainMap, shaded: bool = False, window=None):
    """The terrain with axes in km: a hillshade coloured by height, or filled contours every 100 m.

    With ``window = ((x0, x1), (y0, y1))`` in km the contours are computed on that part of the grid
    only (the same picture inside the window, and a faster redraw). Returns the mappable of the
    heights, for a colour bar.
    """
    vmin, vmax = HEIGHT_RANGE
    extent = np.array(terrain.extent) / KM
    if shaded:
        ax.imshow(hillshade(terrain), origin="lower", extent=extent, cmap="gray")
        mappable = ax.imshow(terrain.heights, origin="lower", extent=extent, cmap="terrain", alpha=0.45,
                             vmin=vmin, vmax=vmax)
    else:
        x, y, h = terrain.x_nodes / KM, terrain.y_nodes / KM, terrain.heights
        if window is not None:
            (x0, x1), (y0, y1) = window
            i = slice(max(np.searchsorted(x, x0) - 1, 0), np.searchsorted(x, x1) + 1)
            j = slice(max(np.searchsorted(y, y0) - 1, 0), np.searchsorted(y, y1) + 1)
            x, y, h = x[i], y[j], h[j, i]
        mappable = ax.contourf(x, y, h, levels=np.arange(200, 1101, 100), cmap="terrain", vmin=vmin, vmax=vmax,
                               alpha=0.7)
    ax.set_xlabel("east x (km)")
    ax.set_ylabel("north y (km)")
    ax.set_aspect("equal")
    ax.grid(False)
    return mappable


def flight_figure(terrain: TerrainMap, flight, mean, cloud, title: str, half_width_km: float = 6.0,
                  max_points: int = 600):
    """One filter run on one flight: one weighted cloud over the map with the true and estimated tracks, and
    the horizontal error over time against the 500 m line that calls a flight lost. ``mean`` ``(K, d)`` is the
    run's estimate (``result.mean``); ``cloud`` one step of it, with ``k``, ``particles`` and ``weights``
    (a :class:`~pfcourse.filter.Step`, e.g. ``result.collected["last_cloud"]`` of a run with
    :class:`~pfcourse.collectors.LastCloud` collected). Returns the figure."""
    k = cloud.k
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 4.2), width_ratios=[1, 1.3], gridspec_kw={"wspace": 0.38})
    c = flight.truth[len(flight.T) // 2, :2] / KM
    window = ((c[0] - half_width_km, c[0] + half_width_km), (c[1] - half_width_km, c[1] + half_width_km))
    fig.colorbar(draw_map(ax1, terrain, window=window), ax=ax1, shrink=0.8, label="terrain height (m)")
    weights = cloud.weights
    n = len(weights)
    idx = np.random.default_rng(0).choice(n, min(n, max_points), p=weights)
    ax1.plot(cloud.particles[idx, 0] / KM, cloud.particles[idx, 1] / KM, ".", ms=2,
             color=COLORS["particles"], label=f"particles at t = {flight.T[k]:.0f} s")
    ax1.plot(flight.truth[:, 0] / KM, flight.truth[:, 1] / KM, color=COLORS["truth"], label="truth")
    # dashed: the estimate's track, told apart from the solid error curve of the same colour
    ax1.plot(mean[:, 0] / KM, mean[:, 1] / KM, color=COLORS["estimate"], ls="--",
             label="estimate (track)")
    ax1.set_xlim(*window[0])
    ax1.set_ylim(*window[1])
    end = mean[k, :2] / KM
    if not (window[0][0] <= end[0] <= window[0][1] and window[1][0] <= end[1] <= window[1][1]):
        ax1.text(0.02, 0.02, f"estimate at t = {flight.T[k]:.0f} s off this window:\n({end[0]:.1f}, {end[1]:.1f}) km",
                 transform=ax1.transAxes, fontsize=8, va="bottom", bbox={"fc": "white", "alpha": 0.8, "lw": 0})
    error = position_error(flight.truth, mean)
    ax2.plot(flight.T, error, color=COLORS["estimate"], label="horizontal error (right)")
    ax2.axhline(DIVERGED_ERROR, color=COLORS["truth"], lw=1, ls=":", label=f"lost above {DIVERGED_ERROR:.0f} m")
    ax2.set_yscale("log")
    ax2.set_ylim(5, 3e4)
    plain_log_axis(ax2, "y")
    ax2.set_xlabel("time t (s)")
    ax2.set_ylabel("error (m)")
    # one legend for both axes, under the figure, off the data
    (h1, l1), (h2, l2) = ax1.get_legend_handles_labels(), ax2.get_legend_handles_labels()
    fig.legend(h1 + h2, l1 + l2, loc="upper center", ncols=3, bbox_to_anchor=(0.5, 0.02), markerscale=4)
    ax2.set_title(f"{title}\nfinal error {error[-1]:.0f} m ({'lost' if error[-1] > DIVERGED_ERROR else 'kept'})")
    return fig
