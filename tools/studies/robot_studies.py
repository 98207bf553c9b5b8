"""Write book/data/robot_studies/: Part III's robot studies, 100 seeded runs per setting.

    python3 tasks.py study robot_studies

Runs every study of pfcourse.experiments.robot_studies.STUDIES with run_study (process pool
over the machine's cores) and stores each table (NAME.csv, NAME.npz for per-step errors);
book/data/robot_studies/provenance.json records what made them. The chapter
book/part3/robot_studies reads them; tests/test_robot_studies_data.py re-computes a seeded
sample of rows.
"""

from __future__ import annotations

import time

import pfcourse  # noqa: F401  (pins the arithmetic first)
from pfcourse.experiments import robot_studies as rs
from pfcourse.experiments.provenance import launch_commit, write_provenance


def main() -> None:
    start, commit = time.time(), launch_commit()
    seconds = {}
    for name in rs.STUDIES:
        t0 = time.time()
        rs.save(name, rs.compute(name))
        seconds[name] = round(time.time() - t0, 1)
        print(f"{name}: {seconds[name]} s", flush=True)
    write_provenance(rs.DATA / "provenance.json", code="tools/studies/robot_studies.py", commit=commit,
                     seconds=time.time() - start, row_code="pfcourse/experiments/robot.py (pf_run)",
                     n_runs=rs.N_RUNS, defaults=rs.DEFAULTS,
                     studies={name: {"grid": grid, "options": options} for name, (grid, options) in rs.STUDIES.items()},
                     seconds_per_study=seconds,
                     seeds="run r: pfcourse.seeding.replicate_seed(0, r), in every study and setting",
                     seconds_column="wall time of one run on a shared 2-core machine: indicative only")


if __name__ == "__main__":
    main()
