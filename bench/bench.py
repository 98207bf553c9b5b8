"""Benchmark: pfcourse's particle filter against a lab-style loop and the `particles` library.

    python3 tasks.py bench                 # everything (about 10 min on the 2-core machine)
    python3 tasks.py bench --quick         # N = 1e3, 1e4 only, one repeat, no notebooks
    python3 tasks.py bench --no-notebooks  # skip the book execution and widget timings

In one session and on the same simulated data (written to a file for the other
environment), it runs three bootstrap filters with the same settings (systematic
resampling when ESS < N/2, the weighted mean as the estimate):

* ``pfcourse``: :class:`pfcourse.filter.ParticleFilter` with the package's models;
* ``loop``: a particle-by-particle Python loop in the style of the lab reports
  (bench/loop_filters.py), for N <= 1e4 only;
* ``particles``: the bootstrap filter of Chopin's `particles` library (bench/particles_runner.py),
  which needs numpy < 2 and so runs in its own virtual environment, bench/.venv-particles,
  made here from the pinned bench/requirements-particles.txt on first use;

on two models: the range-bearing robot (pfcourse.scenarios.robot.scenario, default scenario, 100 steps) and
the linear landmark model (pfcourse.scenarios.landmarks.scenario.circle_scenario, 12 states, 50 steps), for
N = 1e3 ... 1e6.  It reports particle-steps per second (median of several runs), the
ratios against the loop and against `particles`, the peak memory per particle (tracemalloc
peak of one extra run divided by N, the same method in both environments) and each
filter's RMSE (mean and standard deviation over the runs; the runs use seeds 0, 1, ...).
It then executes every notebook of the book in memory (nbclient; the stored notebooks are
not touched) and times one widget update per chapter that has a panel: a call of the
chapter's last panel redrawn at its default values plus a render of the figure with Agg.

The table is written between the markers of the README's benchmark section and the raw
numbers to bench/results.json.  All timings of one invocation come from the same session;
the machine is shared, so absolute speeds move from run to run and ratios are steadier.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
import tracemalloc
import venv
from pathlib import Path

import numba
import numpy as np

from pfcourse.filter import ParticleFilter
from pfcourse.scenarios.landmarks.scenario import circle_scenario, simulate
from pfcourse.scenarios.robot.scenario import RobotModel, simulate_robot

sys.path.insert(0, str(Path(__file__).resolve().parent))
from loop_filters import landmark_loop_filter, robot_loop_filter  # noqa: E402

BENCH = Path(__file__).resolve().parent
ROOT = BENCH.parent
PVENV = BENCH / ".venv-particles"
PREQ = BENCH / "requirements-particles.txt"
README = ROOT / "README.md"
START, END = "<!-- bench:start -->", "<!-- bench:end -->"

ROBOT_STEPS = 100
SIZES = (1_000, 10_000, 100_000, 1_000_000)
REPEATS = {1_000: 7, 10_000: 5, 100_000: 3, 1_000_000: 1}
LOOP_MAX = 10_000
LOOP_REPEATS = {1_000: 2, 10_000: 1}
#: The memory run filters the first MEMORY_STEPS steps only (tracemalloc slows the loop 20-fold).
MEMORY_STEPS = 20
#: tracemalloc on the loop at N = 1e4 would take minutes: its memory is measured at N = 1e3.
LOOP_MEMORY_MAX = 1_000


# --------------------------------------------------------------------------- data
def make_data() -> dict[str, np.ndarray]:
    """The simulated runs and the filters' model parameters, flat, for an .npz file."""
    sim = simulate_robot(rng=0, n_steps=ROBOT_STEPS)
    model = RobotModel.for_simulation(sim)
    sc = circle_scenario()
    lsim = simulate(sc, 0)
    lm = sc.model()
    return {
        "robot_landmarks": sim.landmarks, "robot_odometry": sim.odometry,
        "robot_measurements": sim.measurements, "robot_q_est": model.q_est,
        "robot_r_est": model.r_est, "robot_start": model.start,
        "robot_initial_std": model.initial_std, "robot_dt": np.array(model.dt),
        "robot_truth": sim.truth,
        "landmark_F": lm.F, "landmark_B": lm.B, "landmark_H": lm.H, "landmark_m0": lm.m0,
        "landmark_P0": lm.P0, "landmark_Q": lm.Q, "landmark_R": lm.R, "landmark_Z": lsim.measurements,
        "landmark_truth": lsim.truth,
    }


def sub(data: dict, model: str) -> dict:
    return {k[len(model) + 1:]: v for k, v in data.items() if k.startswith(model + "_")}


def rmse(model: str, truth: np.ndarray, means: np.ndarray) -> float:
    """Robot position RMSE (m) over all steps: the first two state components (both models)."""
    err = np.asarray(means)[:, :2] - truth[:, :2]
    return float(np.sqrt(np.mean(np.sum(err**2, axis=1))))


# --------------------------------------------------------------------------- filters
def pfcourse_runner(model: str, d: dict):
    """A function ``(n, seed) -> means`` running pfcourse's filter on the model ``model``."""
    if model == "robot":
        m = RobotModel(d["landmarks"], d["odometry"], d["q_est"], d["r_est"], dt=float(d["dt"]),
                       start=d["start"], initial_std=d["initial_std"])
        z = d["measurements"]
    else:
        m = circle_scenario().model()
        z = d["Z"]

    def run(n: int, seed: int, steps: int | None = None) -> np.ndarray:
        return ParticleFilter(m, n, threshold=0.5, resampler="systematic").run(z[:steps], seed).mean

    return run


def loop_runner(model: str, d: dict):
    f = robot_loop_filter if model == "robot" else landmark_loop_filter
    key = "measurements" if model == "robot" else "Z"
    return lambda n, seed, steps=None: f({**d, key: d[key][:steps]}, n, seed)


def measure(run, n: int, repeats: int, memory: bool = True) -> dict:
    """Wall times and means of ``repeats`` seeded runs, and the tracemalloc peak of one more (MEMORY_STEPS steps)."""
    times, means = [], []
    for seed in range(repeats):
        t0 = time.perf_counter()
        m = run(n, seed)
        times.append(time.perf_counter() - t0)
        means.append(np.asarray(m).tolist())
    peak = None
    if memory:
        tracemalloc.start()
        run(n, 1000, MEMORY_STEPS)
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
    return {"times": times, "means": means, "peak": peak}


def ensure_particles_venv() -> Path:
    py = PVENV / "bin" / "python"
    stamp = PVENV / ".requirements"
    if not (py.exists() and stamp.exists() and stamp.read_text() == PREQ.read_text()):
        print(f"creating {PVENV} from {PREQ.name}", flush=True)
        venv.EnvBuilder(with_pip=True, clear=True).create(PVENV)
        subprocess.run([str(py), "-m", "pip", "install", "-q", "--disable-pip-version-check",
                        "-r", str(PREQ)], check=True)
        stamp.write_text(PREQ.read_text())
    return py


# --------------------------------------------------------------------------- notebooks
WIDGET_TIMING = """
import time as _time
import matplotlib.pyplot as _plt
from pfcourse.book.panels import redraw_last_panel as _redraw
_plt.switch_backend("Agg")
_plt.close("all")
_times = []
for _ in range(3):
    _t0 = _time.perf_counter()
    _redraw()
    for _num in _plt.get_fignums():
        _plt.figure(_num).canvas.draw()
    _times.append(_time.perf_counter() - _t0)
    _plt.close("all")
print("WIDGET", sorted(_times)[1], sum(_times))
"""


def time_notebooks() -> tuple[dict, dict]:
    """Execute every stored notebook in memory and time it; in chapters with a panel, then time one widget update.

    The widget timing runs in the same kernel after the chapter's last cell (so its
    last panel is the chapter's own), and its duration is not counted in the chapter's time.
    """
    import nbformat
    from nbclient import NotebookClient

    seconds, widgets = {}, {}
    for path in sorted((ROOT / "book").rglob("*.ipynb")):
        if "_build" in path.parts or ".ipynb_checkpoints" in path.parts:
            continue
        nb = nbformat.read(path, as_version=4)
        has_panel = any(c.cell_type == "code" and "control_panel(" in c.source for c in nb.cells)
        if has_panel:
            nb.cells.append(nbformat.v4.new_code_cell(WIDGET_TIMING))
        t0 = time.perf_counter()
        NotebookClient(nb, timeout=1200, kernel_name="python3",
                       resources={"metadata": {"path": str(path.parent)}}).execute()
        elapsed = time.perf_counter() - t0
        rel = str(path.relative_to(ROOT))
        if has_panel:
            text = "".join(o.get("text", "") for o in nb.cells[-1].outputs if o.get("output_type") == "stream")
            median, total = (float(v) for v in text.split("WIDGET")[-1].split()[:2])
            widgets[rel] = median
            elapsed -= total
        seconds[rel] = {"seconds": elapsed}
        print(f"{rel}: executed in {elapsed:.1f} s" + (f", widget update {widgets[rel]:.3f} s" if has_panel else ""),
              flush=True)
    return seconds, widgets


# --------------------------------------------------------------------------- report
def table(results: dict, data: dict) -> str:
    lines = [
        "| model | N | filter | particle-steps/s | vs loop | vs particles | bytes/particle | RMSE (m) |",
        "| --- | ---: | --- | ---: | ---: | ---: | ---: | --- |",
    ]
    steps = {"robot": len(data["robot_measurements"]), "landmark": len(data["landmark_Z"])}
    for model in ("robot", "landmark"):
        truth = data[f"{model}_truth"]
        for n in results["sizes"]:
            rate = {}
            for name in ("pfcourse", "loop", "particles"):
                r = results.get(name, {}).get(f"{model}/{n}")
                if r:
                    rate[name] = n * steps[model] / float(np.median(r["times"]))
            for name in ("pfcourse", "loop", "particles"):
                r = results.get(name, {}).get(f"{model}/{n}")
                if not r:
                    continue
                e = [rmse(model, truth, np.array(m)) for m in r["means"]]
                spread = f" ± {np.std(e, ddof=1):.3f}" if len(e) > 1 else ""
                vs_loop = f"{rate[name] / rate['loop']:.1f}" if "loop" in rate else ""
                vs_part = f"{rate[name] / rate['particles']:.2f}" if "particles" in rate else ""
                lines.append(
                    f"| {model} | {n:.0e} | {name} | {rate[name]:.3g} | {vs_loop} | {vs_part} | "
                    f"{'' if r['peak'] is None else round(r['peak'] / n)} | {np.mean(e):.3f}{spread} ({len(e)} runs) |"
                )
    return "\n".join(lines)


def report(results: dict, data: dict) -> str:
    r = results
    parts = [
        f"Measured by `python3 tasks.py bench` (bench/bench.py) in one session on {r['when']}: "
        f"{r['machine']}, shared with other jobs, so the absolute speeds are indicative and the "
        "ratios, measured in the same run, are the figures to read. Robot: default "
        f"`RobotScenario`, {len(data['robot_measurements'])} steps; landmark: `circle_scenario()`, "
        f"{len(data['landmark_Z'])} steps, 12 states. Speed is the median over the runs (seeds "
        "0, 1, ...) of N × steps / wall time; memory is the tracemalloc peak of one more run "
        f"over the first {MEMORY_STEPS} steps divided by N (not measured for the loop at N = 1e4: "
        "tracemalloc slows it twenty-fold); RMSE is the robot position error, mean ± sd over the runs. "
        f"numpy {np.__version__} and numba {numba.__version__} here (one core for every filter), "
        f"{r.get('particles_numpy', '?')} with particles {r.get('particles_version', '?')}.",
        "",
        table(results, data),
    ]
    if r.get("notebooks"):
        total = sum(v["seconds"] for v in r["notebooks"].values())
        parts += ["", f"Executing every notebook of the book (nbclient, in memory): {total:.0f} s in total ("
                  + ", ".join(f"`{k}` {v['seconds']:.0f} s" for k, v in r["notebooks"].items()) + ")."]
    if r.get("widgets"):
        parts += ["", "One widget update (the chapter's last panel redrawn at its default values, with an Agg "
                  "render, median of 3): " + ", ".join(f"`{k}` {v:.2f} s" for k, v in r["widgets"].items())
                  + "."]
    return "\n".join(parts)


def write_readme(text: str) -> None:
    readme = README.read_text()
    if START not in readme:
        readme = readme.rstrip("\n") + f"\n\n## Benchmark\n\n{START}\n{END}\n"
    head, rest = readme.split(START, 1)
    _, tail = rest.split(END, 1)
    README.write_text(f"{head}{START}\n{text}\n{END}{tail}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="N = 1e3, 1e4, one repeat, no notebooks")
    parser.add_argument("--no-notebooks", action="store_true")
    parser.add_argument("--no-particles", action="store_true")
    parser.add_argument("--no-readme", action="store_true", help="do not rewrite the README section")
    args = parser.parse_args()
    sizes = SIZES[:2] if args.quick else SIZES
    repeats = {n: 1 if args.quick else REPEATS[n] for n in sizes}
    data = make_data()
    results = {"sizes": list(sizes), "when": time.strftime("%Y-%m-%d", time.gmtime()),
               "machine": f"{os.cpu_count()} cores, {platform.machine()}, Python {platform.python_version()}",
               "pfcourse": {}, "loop": {}, "particles": {}}

    py = None if args.no_particles else ensure_particles_venv()
    with tempfile.TemporaryDirectory() as tmp:
        data_file = Path(tmp) / "data.npz"
        np.savez(data_file, **data)
        for model in ("robot", "landmark"):
            d = sub(data, model)
            pf = pfcourse_runner(model, d)
            pf(100, 0)  # warm up
            # interleaved, N by N, so that the three filters see the same load on the shared machine
            for n in sizes:
                key = f"{model}/{n}"
                results["pfcourse"][key] = measure(pf, n, repeats[n])
                print(f"pfcourse {model} N={n}: median {np.median(results['pfcourse'][key]['times']):.3f} s",
                      flush=True)
                if py is not None:
                    out_file = Path(tmp) / "out.json"
                    subprocess.run([str(py), str(BENCH / "particles_runner.py"), str(data_file), str(out_file),
                                    json.dumps([n]), json.dumps({str(n): repeats[n]}), str(MEMORY_STEPS), model],
                                   check=True)
                    out = json.loads(out_file.read_text())
                    results["particles_numpy"] = out.pop("numpy")
                    results["particles_version"] = out.pop("particles")
                    results["particles"].update(out)
                if n <= LOOP_MAX:
                    lr = 1 if args.quick else LOOP_REPEATS[n]
                    results["loop"][key] = measure(loop_runner(model, d), n, lr, n <= LOOP_MEMORY_MAX)
                    print(f"loop {model} N={n}: median {np.median(results['loop'][key]['times']):.3f} s", flush=True)

    if not (args.quick or args.no_notebooks):
        results["notebooks"], results["widgets"] = time_notebooks()

    text = report(results, data)
    print("\n" + text)
    (BENCH / "results.json").write_text(json.dumps(results))
    if not (args.quick or args.no_readme):
        write_readme(text)
        print(f"\nwritten to {README}")


if __name__ == "__main__":
    main()
