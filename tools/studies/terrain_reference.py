"""Write book/data/terrain_reference.csv: a reference posterior for five terrain flights.

    python3 tasks.py study terrain_reference

The exact filtering posterior of the terrain problem has no closed form, and a grid over its four
dimensions (position, altitude, heading) is out of reach; the reference is the bootstrap particle
filter (the consistent one: no kernel, no tempering) run large enough that **doubling N changes
nothing**, which the table itself shows: for each of flights 0-4 (fixed in advance: the first
five), N = 500 000 and N = 1 000 000, two independent filter seeds each, and the posterior mean
and standard deviations of the horizontal position at the final step. "Changes nothing" is
measured in units of the posterior's own spread: the distance between two runs' means divided by
the posterior standard deviation ``sqrt(var_x + var_y)``.

The terrain-cure chapter compares its filters' final estimates with these reference means: how far
from the exact answer a filter is, as against how far the exact answer itself is from the truth.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

import pfcourse  # noqa: F401  (pins the arithmetic first)
from pfcourse.experiments.provenance import launch_commit, write_provenance, write_rows
from pfcourse.filter import ParticleFilter
from pfcourse.seeding import data_rng, reference_rng
from pfcourse.terrain.map import load_jacksboro
from pfcourse.terrain.scenario import AircraftScenario, simulate

ROOT = Path(__file__).resolve().parents[2]
OUT = ROOT / "book" / "data"
FLIGHTS = range(5)
SIZES = (500_000, 1_000_000)
SEEDS = (1, 2)  # filter generator reference_rng(0, flight, seed) = default_rng([0, flight, 100 + seed]): not filter_rng's


def run(flight: int, n: int, seed: int, terrain) -> dict:
    """Bootstrap filter with ``n`` particles on ``flight``: final posterior mean and sd (m), truth."""
    scenario = AircraftScenario()
    sim = simulate(scenario, terrain, data_rng(0, flight))
    pf = ParticleFilter(scenario.model(terrain), n, threshold=0.5, resampler="systematic")
    res = pf.run(sim.measurements, rng=reference_rng(0, flight, seed))
    return {"flight": flight, "N": n, "seed": seed,
            "mean_x": float(res.mean[-1, 0]), "mean_y": float(res.mean[-1, 1]),
            "sd_x": float(np.sqrt(res.cov[-1, 0, 0])), "sd_y": float(np.sqrt(res.cov[-1, 1, 1])),
            "true_x": float(sim.truth[-1, 0]), "true_y": float(sim.truth[-1, 1])}


def main() -> None:
    start, commit = time.time(), launch_commit()
    terrain = load_jacksboro()
    rows = []
    for flight in FLIGHTS:
        for n in SIZES:
            for seed in SEEDS:
                t0 = time.perf_counter()
                row = run(flight, n, seed, terrain)
                row["seconds"] = round(time.perf_counter() - t0, 2)
                rows.append(row)
                print(row, flush=True)
    write_rows(OUT / "terrain_reference.csv", rows)
    write_provenance(OUT / "terrain_reference.json", code="tools/studies/terrain_reference.py", commit=commit,
                     seconds=time.time() - start, row_code="tools/studies/terrain_reference.py (run)",
                     flights=list(FLIGHTS), sizes=list(SIZES), seeds="flight r: pfcourse.seeding.data_rng(0, r) = default_rng([0, r, 0]); filter: "
                     "pfcourse.seeding.reference_rng(0, r, seed) = default_rng([0, r, 100 + seed]), seed in (1, 2)",
                     filter="bootstrap, systematic resampling at ESS < N/2")


if __name__ == "__main__":
    main()
