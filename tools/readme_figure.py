"""Make docs/readme-figure.png, the figure shown in the README.

    .venv/bin/python tools/readme_figure.py

Left: one run of the two-landmark model, the exact (Kalman) estimate and an SIR
particle filter with its final cloud. Right: the effective sample size of SIS and
SIR over time, median and 10-90 % band over 50 seeded runs.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from pfcourse import ParticleFilter, kalman_filter  # noqa: E402
from pfcourse.collectors import Clouds  # noqa: E402
from pfcourse.scenarios.landmarks.scenario import quadrant_scenario, simulate  # noqa: E402
from pfcourse.book.style import COLORS, use_style  # noqa: E402

N, RUNS = 1000, 50


def main() -> None:
    use_style()
    scenario = quadrant_scenario()
    model = scenario.model()
    sim = simulate(scenario, 2024)
    kf = kalman_filter(model, sim.measurements)
    sir = ParticleFilter(model, N, threshold=0.5).run(sim.measurements, rng=1, collect=[Clouds()])

    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.6), width_ratios=[1, 1.25])
    ax1.plot(*sim.truth[:, :2].T, color=COLORS["truth"], lw=1, label="true robot path")
    ax1.plot(*kf.mean[:, :2].T, color=COLORS["kalman"], lw=1.5, label="Kalman (exact posterior mean)")
    ax1.plot(*sir.mean[:, :2].T, "--", color=COLORS["estimate"], lw=1.5, label=f"SIR particle filter, N = {N}")
    cloud = sir.particles[-1]
    ax1.scatter(cloud[:, 0], cloud[:, 1], s=4, color=COLORS["particles"], alpha=0.4, label="particles at t = 49 s")
    for j in range(scenario.n_landmarks):
        ax1.plot(*sim.truth[-1, 2 + 2 * j : 4 + 2 * j], "s", ms=9, mec="k", color=COLORS["seen"])
    ax1.set(xlabel="x (m)", ylabel="y (m)", aspect="equal", title="Robot and two landmarks (squares)")
    ax1.legend(loc="center", fontsize=7)

    for threshold, name, color in ((0.0, "SIS (never resample)", "tab:purple"), (0.5, "SIR (resample when ESS < N/2)", COLORS["estimate"])):
        ess = np.array([ParticleFilter(model, N, threshold=threshold).run(sim.measurements, rng=seed).ess for seed in range(RUNS)])
        lo, med, hi = np.percentile(ess, [10, 50, 90], axis=0)
        ax2.fill_between(sim.T, lo, hi, color=color, alpha=0.2)
        ax2.plot(sim.T, med, color=color, label=name)
    ax2.set(yscale="log", xlabel="time t (s)", ylabel="effective sample size",
            title=f"Weight degeneracy: median and 10-90 % band, {RUNS} runs")
    ax2.legend(loc="lower left")
    fig.tight_layout()
    out = Path(__file__).resolve().parents[1] / "docs" / "readme-figure.png"
    fig.savefig(out, dpi=90, metadata={"Software": None})
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
